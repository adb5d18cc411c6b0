"""Signal processing: numpy and scipy only, never Qt."""
