"""Baselines the paper compares against, each a ``Localiser`` fed the same sensor frames.

- :class:`~ppaloc.baselines.seqslam.SeqSLAM`: SeqSLAM (Milford & Wyeth 2012), past-only and
  incremental by default, OpenSeqSLAM's centred window offline;
- :class:`~ppaloc.baselines.ablem.ABLEM`: ABLE-M (Arroyo et al.), sequences of global
  LDB-style binary codes matched by Hamming distance;
- :class:`~ppaloc.baselines.particle.ParticleFilter`: a seeded 1-D particle filter over
  map nodes (after Liu & Zhang);
- :class:`~ppaloc.baselines.single.SingleFrame`: the best single-frame match.

SeqSLAM, the particle filter and single-frame matching compare SeqSLAM's patch-normalised
image by default, or the weighted-node filter's own place (``descriptor="lowres"``,
``"lowres16"``, ``"lbp"`` or ``"haar"``); ABLE-M its LDB code or the filter's LBP code.
See docs/baselines.md for every parameter and each deviation from the original.
"""

from ppaloc.baselines.ablem import ABLEM
from ppaloc.baselines.particle import ParticleFilter
from ppaloc.baselines.seqslam import SeqSLAM
from ppaloc.baselines.single import SingleFrame

__all__ = ["ABLEM", "ParticleFilter", "SeqSLAM", "SingleFrame"]
