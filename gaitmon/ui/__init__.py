"""Desktop user interface. The only package in gaitmon that imports Qt (PySide6, pyqtgraph)."""
