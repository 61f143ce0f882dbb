# The transport's acknowledgement on links whose modem reports by itself
# whether a frame of more than half its MTU reached its addressee (the
# driver's caps flag CAP_DELIVERY: an EvoLogics S2C acknowledges every burst
# itself and says DELIVERED or FAILED, at no extra air time).
#
# To the packet's destination the reports are the acknowledgement. The
# fragments the modem reports on ask for no SACK (their poll flag is off),
# and the round is over when the last of its reports is in:
# - every fragment DELIVERED: the transfer is complete;
# - some DELIVERED, some FAILED: the modem heard the receiver's
#   acknowledgement, so the FAILED ones are missing, and the next round
#   sends them at once;
# - none DELIVERED: the acknowledgement may be what was lost (the modem
#   says FAILED then for bursts that arrived), so a bare poll asks the
#   receiver, whose SACK says what is missing for a few bytes.
# Without the SACK after each round a transfer ends when the modem's
# acknowledgement comes back, a SACK's airtime and turnaround sooner, and the
# receiver does not transmit while the sender may already send its next
# packet. What a report cannot tell: that the destination's host took the
# packet. A destination drops a packet that its modem acknowledged only when
# it is over its max_packet, when it holds 8 reassemblies at once, or, in
# strict mode, when it was not sealed with the key (acomm.transport); the
# sender has then said delivered, and counts the refusal, if one comes, as a
# bad segment.
#
# To a relay the SACK stays the authority: the relay may be full, and only
# its SACK says it took custody. The reports acknowledge the fragments that
# do not carry the poll, as if a SACK had listed them; a SACK that says a
# reported fragment is missing (the relay dropped its reassembly) puts it
# back, and only a completion SACK completes the transfer.
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

# ReportedOutgoing.reports: 1 the reports acknowledge fragments, 2 they are
# the acknowledgement (to the packet's destination)
REPORTS_ACK = 2
# what a report means for the transfer (ReportedOutgoing.reported)
REPORT_COMPLETE = 1
REPORT_NEW_ROUND = 2
REPORT_REPOLL = 3


class ReportedOutgoing(Outgoing):
    """An Outgoing on a link whose modem reports the delivery of frames of more than half its MTU."""

    reports = 1
    heard = False  # a report of this round said DELIVERED: the modem heard an acknowledgement

    def __init__(self, blob, fragsize, lane, gen, pid, to_destination):
        # segments of at least report_min bytes (index byte included) fill
        # more than half the link's MTU: the modem reports them
        self.report_min = (fragsize + sg.FRAG_HEADER) // 2 + 1
        # to the packet's destination, the reports are the acknowledgement;
        # a relay's SACK says whether it took custody (it may be full)
        if to_destination:
            self.reports = REPORTS_ACK
        n = len(blob)
        if fragsize > 0 and n > fragsize:
            # as many fragments as the MTU needs, all of one size
            count = (n + fragsize - 1) // fragsize
            fragsize = (n + count - 1) // count
        Outgoing.__init__(self, blob, fragsize, lane, gen, pid)

    def fragment(self, index, poll):
        # to the destination, a fragment the modem reports on asks for no
        # SACK: its report says whether it arrived
        if poll and self.reports == REPORTS_ACK:
            size = len(self.blob) - index * self.fragsize
            if size > self.fragsize:
                size = self.fragsize
            poll = size + sg.FRAG_HEADER < self.report_min
        return Outgoing.fragment(self, index, poll)

    def new_round(self):
        self.heard = False
        return Outgoing.new_round(self)

    def report_wanted(self, nbytes, poll):
        """True when a segment of nbytes (index byte included) is to be confirmed by the modem's report."""
        return nbytes >= self.report_min and not poll

    def reported(self, index, delivered, more):
        """The modem's report on the fragment at index; more: other reports of this transfer are to come.

        DELIVERED acknowledges the fragment, as if a SACK had listed it. To
        a relay that is all (its SACK completes the transfer) and this
        returns 0. To the destination it returns REPORT_COMPLETE when every
        fragment is acknowledged; once the round is sent and its reports
        are all in, REPORT_NEW_ROUND when one said DELIVERED (the modem
        heard the acknowledgement: the FAILED ones are missing) and
        REPORT_REPOLL when none did (the acknowledgement may be what was
        lost: a bare poll's SACK tells); otherwise 0."""
        if delivered and 0 <= index < self.count and not self.complete:
            self.heard = True
            self.acked[index] = 1
            while self.base < self.count and self.acked[self.base]:
                self.base += 1
        if self.reports != REPORTS_ACK:
            return 0
        if self.base >= self.count:
            self.complete = True
            return REPORT_COMPLETE
        if more or self.sent_in_round < len(self.round):
            return 0
        return REPORT_NEW_ROUND if self.heard else REPORT_REPOLL
