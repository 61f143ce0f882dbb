# python -m acomm_cpython.cli: the acomm command without its console script
import sys

from . import main

sys.exit(main())
