"""Stage 2, synthesis: grow a large texture from a small sample (Liang et al. 2001
patch-based sampling, minimum-error cut, seamless wrap; paper section 2.1), and the
quality measures that judge it (:mod:`texcad.synthesis.quality`).
"""

from . import quality
from .quilt import BLENDS, WRAPS, naive_quilt, patch_grid, seam_bands, synthesize

__all__ = ["synthesize", "naive_quilt", "seam_bands", "patch_grid", "BLENDS", "WRAPS", "quality"]
