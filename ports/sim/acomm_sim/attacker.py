# An attacker without the network key on the simulated acoustic channel:
# a software-defined transceiver that speaks the SeaTrac air protocol
# (acomm_sim.seatrac_xcvr's packets), so it hears every packet in range and
# puts packets on the water with any source and destination beacon id it
# likes (a SeaTrac's id is a setting; a packet carries no proof of it).
#
# What it does with what it hears is up to its owner (acomm bench attack):
# heard(t, packet) is called for every packet that reaches it, and
# send(now, src, dst, data) transmits a one-way DAT packet as if from src.
# It never sends on its own.

from acomm.drivers import seatrac_codes as sc

from .seatrac_xcvr import PROTO_DAT, Packet

PACKET_MS = 500  # a SeaTrac DAT packet: 500 ms + 80 ms a byte (seatrac_xcvr)
BYTE_MS = 80


class Attacker:
    def __init__(self, channel, addr, position, heard=None):
        self.channel = channel
        self.addr = addr
        self.heard = heard
        self.sent = 0
        self.heard_count = 0
        channel.attach(addr, self)
        channel.set_position(addr, position[0], position[1], position[2])

    def receive(self, t, src, p, dist):
        # the medium's delivery: every packet in range, whoever it was for
        self.heard_count += 1
        if self.heard is not None:
            self.heard(t, p)

    def send(self, now, src, dst, data, mtype=sc.MSG_OWAY):
        # -> when the packet has left; it arrives as from beacon src
        self.sent += 1
        return self.channel.transmit(now, self.addr, Packet(PROTO_DAT, src, dst, mtype, bytes(data)),
                                     PACKET_MS + BYTE_MS * len(data))
