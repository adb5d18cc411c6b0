"""The review window: a recorded session browsed, analysed, reported and exported."""
