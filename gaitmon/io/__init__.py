"""Device link and storage: protocol, decoder, transports, simulated unit, session files.

No Qt here: only numpy, scipy, pyserial and h5py."""
