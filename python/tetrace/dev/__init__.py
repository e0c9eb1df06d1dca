"""Developer tooling: cameras and random rays, images, synthetic scenes, comparisons, the
stress families and the demo. Not imported by ``import tetrace``."""
