import sys

from rodfem.app.cli import main

sys.exit(main())
