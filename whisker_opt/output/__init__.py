"""What a run writes: atomic files, CSV/JSON tables and the plots."""
