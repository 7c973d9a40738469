"""FastSLAM 1.0 and 2.0: the Rao-Blackwellised particle filter for landmark SLAM (:mod:`.filter`), its
copy-on-write landmark storage (:mod:`.storage`), the per-particle update (:mod:`.kernels`) and the
sequence runner (:mod:`.run`)."""

from .filter import FastSLAM, FastSLAMParams
from .run import run_sequence

FastSLAM.run = run_sequence  # bound here, so that filter.py does not import its runner

__all__ = ["FastSLAM", "FastSLAMParams"]
