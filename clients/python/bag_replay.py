#!/usr/bin/env python3
"""A ROS 2 bag through a running attitude-service over its ROS 2 edge: the thin entry of the client package's
``attitude-bag-replay`` (``attitude_client.bag_replay``; install with ``pip install 'clients/python[ros2]'``).

    clients/python/bag_replay.py BAG [--connect tcp/127.0.0.1:7447] [--truth TOPIC] [--json]
"""

import pathlib
import sys

try:
    from attitude_client.bag_replay import main
except ImportError:  # run from a checkout without the package installed
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent / "src"))
    from attitude_client.bag_replay import main

if __name__ == "__main__":
    sys.exit(main())
