"""Independent Python reference model of the SpurGearMesh FMU (see gearmesh_ref.py)."""
