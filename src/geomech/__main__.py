import sys

from _geomech_cli import main

sys.exit(main())
