import sys

from ogacq.cli.app import main

sys.exit(main())
