# Gateways from acomm to other protocols: imcbridge (IMC over UDP for DUNE
# and Neptus: sockets, discovery, the loop) and imcnodes (the acomm nodes a
# bridge serves, simulated or on modems). Imports the library and acomm_sim.
