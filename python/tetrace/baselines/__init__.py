"""Reference ray casters tetrace is measured against (Embree through embreex)."""
