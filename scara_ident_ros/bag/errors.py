"""The one exception of the bag package."""
from __future__ import annotations

from scara_ident_ros.errors import ScaraIdentError

__all__ = ['BagError']


class BagError(ScaraIdentError):
    """A bag cannot be read, written or recovered.

    The message is one line that says what went wrong and where (the path, and the
    file offset or message number when known), e.g.
    ``'/data/run1/bag_0.mcap: truncated MCAP file (1048576 bytes, no footer; was the
    recorder killed?): recover it with: scara-ident recover /data/run1'``.
    """
