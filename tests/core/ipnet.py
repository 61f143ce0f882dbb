# A fake IP network for the datagram driver's tests on both runtimes: ports
# with the pump(now) API of the CPython socket ports, joined by a router
# that delivers datagrams by endpoint, a multicast group to every member
# (the sender too, as IP_MULTICAST_LOOP does), and can lose or inject them.


class FakeNet:
    def __init__(self, group=("239.255.97.99", 29799)):
        self.group = group
        self.ports = {}  # endpoint -> FakePort
        self.in_flight = []  # (src endpoint, dst endpoint, data)
        self.lose = None  # f(src, dst, data) -> True to drop

    def port(self, driver, endpoint, join=True):
        p = FakePort(self, driver, endpoint, join)
        self.ports[endpoint] = p
        return p

    def inject(self, src, dst, data):
        self.in_flight.append((src, dst, data))

    def deliver(self):
        pending = self.in_flight
        self.in_flight = []
        for src, dst, data in pending:
            if self.lose is not None and self.lose(src, dst, data):
                continue
            if dst == self.group:
                for p in self.ports.values():
                    if p.joined:
                        p.inbox.append((src, data))
            else:
                p = self.ports.get(dst)
                if p is not None:
                    p.inbox.append((src, data))


class FakePort:
    def __init__(self, net, driver, endpoint, join):
        self.net = net
        self.driver = driver
        self.endpoint = endpoint
        self.joined = join
        self.inbox = []
        self.refuse = None  # an error string: every send fails with it
        if join:
            driver.broadcast_endpoints = [net.group]

    def pump(self, now):
        d = self.driver
        self.net.deliver()
        inbox = self.inbox
        self.inbox = []
        for src, data in inbox:
            d.feed_from(now, src, data)
        for h, ep, data in d.take_datagrams():
            if self.refuse is not None:
                d.sent(now, h, self.refuse)
                continue
            self.net.in_flight.append((self.endpoint, ep, data))
            d.sent(now, h)
