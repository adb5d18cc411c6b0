"""Lab Streaming Layer: gaitmon's streams (``layout``), the outlets, the marker inlet and remote
start/stop (optional extra ``gaitmon[lsl]``, pylsl), and the XDF import (pyxdf). Nothing here
opens a socket unless LSL is enabled by the user."""
