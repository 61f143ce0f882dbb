# Stands in for $(PORT_DIR)/boards/manifest.py (which only some ports have)
# when tools/firmware.py builds the qemu and unix ports: what a board's own
# port manifest would freeze that acomm needs, asyncio.
include("$(MPY_DIR)/extmod/asyncio")
