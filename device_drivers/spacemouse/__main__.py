"""openpendant spacemouse [--source hid|spacenavd|replay] [--name NAME] [--port 0]"""

import sys

from openpendant.runtime.drivers.run import run_driver

if __name__ == "__main__":
    sys.exit(run_driver("spacemouse"))
