# The transport's implicit acknowledgement, on links whose modem reports by
# itself whether a frame of more than half its MTU reached its addressee (the
# driver's caps flag CAP_DELIVERY: an EvoLogics S2C acknowledges every burst
# itself and says DELIVERED or FAILED, at no extra air time).
#
# The sender asks the link to confirm each fragment the modem reports on,
# except the one that carries the poll, and takes the modem's DELIVERED as
# the receiver's word for that fragment: it counts as acknowledged at once,
# as if a SACK had listed it. The peer's SACK stays the authority: it still
# completes the transfer (only a completion SACK does), and a SACK that says
# the receiver lacks fragments the modem reported delivered (its reassembly
# was dropped) puts them back (acomm.transport.arq Outgoing.on_sack). A
# report twice, or a report and a SACK for the same fragment, changes
# nothing.
#
# What is not done, and why (docs/transport.md has the measurements):
# - a FAILED fragment is not sent again at once but in the next round, from
#   the SACK: the modem says FAILED when its acknowledgement was lost as
#   often as when the burst was, and where it acknowledges a train of
#   bursts with one packet (the emulator does), one lost acknowledgement
#   fails a whole train that arrived. The SACK, which always follows (the poll goes last), says what
#   is missing for a few bytes. Sent at once, the 4 KiB transfer took longer
#   at 10 and 20 % loss;
# - the poll's own fragment is not reported: the link keeps at most
#   ack_window (4) frames waiting for their report, and a fifth would hold
#   the poll back until the train's acknowledgement, off the train.
#
# Burst sizing: the fragments of a packet are made equal (at most the link's
# MTU), so the last one is not a runt that goes as an instant message (on
# the S2C: a slower bit rate, 150 ms of preamble for a few bytes, and not in
# the train of bursts).
#
# A module of its own, imported by the transport only when a transfer starts
# on such a link: a board whose links report nothing (the buoy's SeaTrac and
# Iridium) never loads it.

from . import segment as sg
from .arq import Outgoing


class ReportedOutgoing(Outgoing):
    """An Outgoing on a link whose modem reports the delivery of frames of more than half its MTU."""

    reports = True

    def __init__(self, blob, fragsize, lane, gen, pid):
        # segments of at least report_min bytes (index byte included) fill
        # more than half the link's MTU: the modem reports them
        self.report_min = (fragsize + sg.FRAG_HEADER) // 2 + 1
        n = len(blob)
        if fragsize > 0 and n > fragsize:
            # as many fragments as the MTU needs, all of one size
            count = (n + fragsize - 1) // fragsize
            fragsize = (n + count - 1) // count
        Outgoing.__init__(self, blob, fragsize, lane, gen, pid)

    def report_wanted(self, nbytes, poll):
        """True when a segment of nbytes (index byte included) is to be confirmed by the modem's report."""
        return not poll and nbytes >= self.report_min

    def reported(self, index):
        """The modem reported the fragment at index delivered: acknowledged, as by a SACK."""
        if 0 <= index < self.count and not self.complete:
            self.acked[index] = 1
            while self.base < self.count and self.acked[self.base]:
                self.base += 1
