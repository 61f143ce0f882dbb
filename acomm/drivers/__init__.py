# Sans-IO drivers: one protocol machine per interface. Each takes bytes from
# the device and the current time, and gives back bytes to write and events
# (acomm.events EV_*). The interface every driver offers to acomm.link.Link:
#
#   caps                          acomm.drivers.caps.Capabilities
#   broadcast_addr                interface address meaning "everyone"
#   ready(now) -> bool            can start a new send or ping now
#   send(now, addr, data, ack) -> handle    start transmitting one frame
#   ping(now, addr) -> handle     ranging drivers only
#   feed(now, data)               bytes read from the device
#   poll(now)                     let timers run
#   take_events() -> list         events since the last call
#   take_output() -> bytes        bytes to write to the device (b"" if none)
