"""python -m lccopt: the same as the lccopt command."""
import sys

from lccopt.cli import main

sys.exit(main())
