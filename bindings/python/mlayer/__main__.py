"""python -m mlayer: the same as the `mlayer` command."""
import sys

from .cli import main

sys.exit(main())
