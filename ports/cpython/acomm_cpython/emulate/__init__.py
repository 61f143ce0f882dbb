# The I/O around the simulator's emulated modems (acomm_sim): the emulator
# host on pseudo-terminals and TCP (host, pty), the capture format and its
# replay through a driver (capture, replay, capture_sessions), taps that read
# a serial line in acomm's terms (modemtaps), and the simulated ocean around
# an emulated board (picoocean). Imports the library and acomm_sim.
