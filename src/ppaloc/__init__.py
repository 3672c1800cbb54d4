"""ppaloc: weighted node mapping and localisation on a (simulated) pixel processor array.

The package is layered (see docs/architecture.md): ``sim`` (the SCAMP-5 simulator),
``place`` (node representations), ``topomap`` (the map), ``localise`` (the weighted-node
filter on the host), ``onsensor`` (the same filter as PPA programs), ``baselines``,
``datasets``, ``evaluate`` and ``cli``. Data flows one way: dataset -> sensor front-end ->
localiser -> estimates -> evaluation -> report.
"""

import logging

from ppaloc.errors import PpalocError

__all__ = ["PpalocError", "__version__"]
__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())
