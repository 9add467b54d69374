"""``python -m scara_ident_ros.cli``: the same as the ``scara-ident`` console script."""
import sys

from scara_ident_ros.cli import main

sys.exit(main())
