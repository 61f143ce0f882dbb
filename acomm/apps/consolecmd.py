# The operator's commands of a console (acomm.apps.console.ConsoleState):
# a dict in, as parsed from JSON, and out either a validated call on the
# node (Link.request, Link.range, Link.cancel), logged with who sent it, or
# a 4xx code with the reason. Kept apart from the state's views, which need
# none of this until an operator types.

from ..compat import const
from ..errors import AcommError

_TEXT_MAX = const(200)  # longest text an operator may type (the catalog's own limit applies)

# the operator's catalog commands: catalog -> names accepted
SEAWARE_COMMANDS = ("start_mission", "stop_mission", "rendezvous_on", "rendezvous_off")


class Refused(Exception):
    # a command the console will not carry out: code (a 4xx) and reason
    def __init__(self, code, reason):
        super().__init__(reason)
        self.code = code
        self.reason = reason


def execute(st, now, cmd, who):
    """The command dict cmd from who, on ConsoleState st -> (HTTP code, answer dict); never raises."""
    try:
        if not isinstance(cmd, dict):
            raise Refused(400, "a command is a JSON object")
        op = cmd.get("op")
        if op == "chat":
            ans = _chat(st, now, cmd, who)
        elif op == "command":
            ans = _catalog_command(st, now, cmd, who)
        elif op == "cancel":
            ans = _cancel(st, now, cmd, who)
        elif op == "range":
            ans = _range(st, now, cmd, who)
        elif op == "ack":
            ans = _ack(st, now, cmd, who)
        else:
            raise Refused(400, "unknown op %r: chat, command, cancel, range or ack" % (op,))
    except Refused as e:
        st.rejected += 1
        return e.code, {"error": e.reason}
    st.commands += 1
    return ans


def _dst(st, cmd):
    dst = cmd.get("dst")
    if not isinstance(dst, str) or not dst:
        raise Refused(400, "dst: a node name is needed")
    if st.node.names.id_of(dst) is None:
        raise Refused(404, "unknown node %r" % dst)
    if dst == st.node.name:
        raise Refused(400, "%r is this node" % dst)
    return dst


def _link_for(st, cmd, dst, need_ranging=False):
    # the link asked for, else the first that has heard dst, else the first
    node = st.node
    lname = cmd.get("link")
    if lname is not None:
        if lname not in node.links:
            raise Refused(404, "unknown link %r" % (lname,))
        return node.links[lname]
    first = None
    for k in node.links:
        link = node.links[k]
        if need_ranging and "ranging" not in link.caps.flag_names():
            continue
        if link.availability(dst) == 1:
            return link
        if first is None:
            first = link
    if first is None:
        raise Refused(409, "no link of this node can %s" % ("range" if need_ranging else "send"))
    return first


def _send(st, now, cmd, who, dst, data, cls, text):
    link = _link_for(st, cmd, dst)
    rid = st.node.next_req_id()
    e = st.add_log(now, "tx", cls, dst, text, link.name, rid, who)
    if not link.request(now, rid, dst, data, st.lifespan_s, st.priority, True):
        _refused(e, "queued")
    return 202, {"req": rid, "link": link.name, "log": e["id"]}


def _refused(e, what):
    # the link said no (its `failed` status, with the reason, reached
    # the log when this console hears the node's events)
    raise Refused(409, "not %s: %s" % (what, e.get("reason") or "refused by the link"))


def _chat(st, now, cmd, who):
    dst = _dst(st, cmd)
    text = cmd.get("text")
    if not isinstance(text, str) or not text or len(text) > _TEXT_MAX:
        raise Refused(400, "text: 1 to %d characters" % _TEXT_MAX)
    from ..catalog import caddy

    try:
        data = caddy.CATALOG.pack([(caddy.CHAT, {"text": text})])
    except AcommError as e:
        raise Refused(400, "text: %s" % e)
    return _send(st, now, cmd, who, dst, data, "chat", text)


def _catalog_command(st, now, cmd, who):
    dst = _dst(st, cmd)
    cat, name = cmd.get("catalog"), cmd.get("name")
    if cat == "caddy":
        from ..catalog import caddy

        if name not in caddy.COMMANDS:
            raise Refused(400, "name: one of the CADDY commands %s" % ", ".join(caddy.COMMANDS))
        data = caddy.CATALOG.pack([(caddy.COMMAND, {"command": name})])
    elif cat == "seaware":
        from ..catalog import seaware

        if name not in SEAWARE_COMMANDS:
            raise Refused(400, "name: one of the Seaware commands %s" % ", ".join(SEAWARE_COMMANDS))
        data = seaware.encode(st.node.node_id & seaware.MAX_ADDR, name)
    else:
        raise Refused(400, "catalog: caddy or seaware")
    return _send(st, now, cmd, who, dst, data, "command", "%s %s" % (cat, name))


def _cancel(st, now, cmd, who):
    req, lname = cmd.get("req"), cmd.get("link")
    if not isinstance(req, int) or isinstance(req, bool):
        raise Refused(400, "req: the request id to cancel")
    links = [lname] if lname is not None else list(st.node.links)
    for k in links:
        if k not in st.node.links:
            raise Refused(404, "unknown link %r" % (k,))
        if st.node.links[k].cancel(now, req, "canceled by %s" % who):
            st.add_log(now, "op", "cancel", None, "request %d canceled" % req, k, None, who)
            return 200, {"canceled": req, "link": k}
    raise Refused(404, "no open request %d" % req)


def _range(st, now, cmd, who):
    dst = _dst(st, cmd)
    link = _link_for(st, cmd, dst, True)
    if "ranging" not in link.caps.flag_names():
        raise Refused(409, "link %s cannot measure range" % link.name)
    rid = st.node.next_req_id()
    e = st.add_log(now, "tx", "range", dst, "range " + dst, link.name, rid, who)
    if not link.range(now, rid, [dst], st.lifespan_s):
        _refused(e, "ranged")
    return 202, {"req": rid, "link": link.name, "log": e["id"]}


def _ack(st, now, cmd, who):
    aid = cmd.get("alarm")
    for a in st.alarms:
        if a["id"] == aid:
            if a["acked_by"] is None:
                a["acked_by"] = who
                a["acked_t"] = st.t_s(now)
                st.add_log(now, "op", "ack", a["from"], "alarm %d acknowledged" % aid, None, None, who)
                st.bump("alarms")
            return 200, {"alarm": aid, "acked_by": a["acked_by"]}
    raise Refused(404, "no alarm %r" % (aid,))
