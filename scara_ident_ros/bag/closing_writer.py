"""What a writer does at the end of a ``with`` block: finish the file, or leave it as it is.

A ``with`` block that ends normally closes the writer (summary, footer, metadata); one that
ends with an exception aborts it, so that a failed recording is not dressed up as a complete
one (:func:`~scara_ident_ros.bag.recover_bag` makes it readable). Both writers of the
package, :class:`~scara_ident_ros.bag.mcap_file.McapFileWriter` and
:class:`~scara_ident_ros.bag.writer.BagWriter`, are such writers.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from types import TracebackType
from typing import TypeVar

__all__ = ['ClosingWriter']

_W = TypeVar('_W', bound='ClosingWriter')


class ClosingWriter(ABC):
    """A writer used as a context manager: closed on success, aborted on an exception."""

    @abstractmethod
    def close(self) -> object:
        """Finish what is written (a complete, readable file)."""

    @abstractmethod
    def abort(self) -> None:
        """Stop writing and leave what is written as it is."""

    def __enter__(self: _W) -> _W:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
