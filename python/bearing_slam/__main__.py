import sys

from bearing_slam.cli import main

sys.exit(main())
