"""openpendant sim-robot --model ur5 --name cell-2-ur5 [--port 0]"""

import sys

from openpendant.runtime.drivers.run import run_driver

if __name__ == "__main__":
    sys.exit(run_driver("sim-robot"))
