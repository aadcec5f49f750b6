import sys

from bearing_slam.cli import main

if __name__ == "__main__":  # not on import (e.g. by a documentation generator)
    sys.exit(main())
