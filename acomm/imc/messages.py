# The IMC 5.4 messages acomm knows (ref/imc.md section 2; field order is
# wire order). Each is one line: id, abbrev, and "name:type ..." with IMC's
# type names. A line is parsed into (mgid, abbrev, ((field, code), ...)) the
# first time the message is used, so a board pays RAM only for the messages
# it meets. define() adds more (third parties use ids >= 1000).

from ..errors import EncodeError
from .wire import TYPE_CODES

_TABLE = (
    (150, "Heartbeat", ""),
    (151, "Announce", "sys_name:plaintext sys_type:uint8 owner:uint16 lat:fp64 lon:fp64 height:fp32 services:plaintext"),
    (152, "AnnounceService", "service:plaintext service_type:uint8"),
    (153, "RSSI", "value:fp32"),
    (155, "LinkLevel", "value:fp32"),
    (156, "Sms", "number:plaintext timeout:uint16 contents:plaintext"),
    (157, "SmsTx", "seq:uint32 destination:plaintext timeout:uint16 data:rawdata"),
    (158, "SmsRx", "source:plaintext data:rawdata"),
    (159, "SmsState", "seq:uint32 state:uint8 error:plaintext"),
    (170, "IridiumMsgRx", "origin:plaintext htime:fp64 lat:fp64 lon:fp64 data:rawdata"),
    (171, "IridiumMsgTx", "req_id:uint16 ttl:uint16 destination:plaintext data:rawdata"),
    (172, "IridiumTxStatus", "req_id:uint16 status:uint8 text:plaintext"),
    (182, "LinkLatency", "value:fp32 sys_src:uint16"),
    (183, "ExtendedRSSI", "value:fp32 units:uint8"),
    (185, "CompressedHistory", "base_lat:fp32 base_lon:fp32 base_time:fp32 data:rawdata"),
    (189, "CommSystemsQuery", "type:uint8 comm_interface:uint16 model:uint16 list:plaintext"),
    (190, "TelemetryMsg", "type:uint8 req_id:uint32 ttl:uint16 code:uint8 destination:plaintext source:plaintext acknowledge:uint8 status:uint8 data:rawdata"),
    (206, "AcousticMessage", "message:message"),
    (207, "SimAcousticMessage", "lat:fp64 lon:fp64 depth:fp32 sentence:plaintext txtime:fp64 modem_type:plaintext sys_src:plaintext seq:uint16 sys_dst:plaintext flags:uint8 data:rawdata"),
    (211, "AcousticOperation", "op:uint8 system:plaintext range:fp32 msg:message"),
    (212, "AcousticSystemsQuery", ""),
    (213, "AcousticSystems", "list:plaintext"),
    (214, "AcousticLink", "peer:plaintext rssi:fp32 integrity:uint16"),
    (215, "AcousticRequest", "req_id:uint16 destination:plaintext timeout:fp64 range:fp32 type:uint8 msg:message"),
    (216, "AcousticStatus", "req_id:uint16 type:uint8 status:uint8 info:plaintext range:fp32"),
    (217, "AcousticRelease", "system:plaintext op:uint8"),
    (273, "DevDataText", "value:plaintext"),
    (274, "DevDataBinary", "value:rawdata"),
    (515, "TransmissionRequest", "req_id:uint16 comm_mean:uint8 destination:plaintext deadline:fp64 range:fp32 data_mode:uint8 msg_data:message txt_data:plaintext raw_data:rawdata"),
    (516, "TransmissionStatus", "req_id:uint16 status:uint8 range:fp32 info:plaintext"),
    (517, "SmsRequest", "req_id:uint16 destination:plaintext timeout:fp64 sms_text:plaintext"),
    (518, "SmsStatus", "req_id:uint16 status:uint8 info:plaintext"),
    (521, "TCPRequest", "req_id:uint16 destination:plaintext timeout:fp64 msg_data:message"),
    (522, "TCPStatus", "req_id:uint16 status:uint8 info:plaintext"),
    (550, "Abort", ""),
    (650, "VehicleLinks", "localname:plaintext links:message-list"),
    (814, "UamTxFrame", "seq:uint16 sys_dst:plaintext flags:uint8 data:rawdata"),
    (815, "UamRxFrame", "sys_src:plaintext sys_dst:plaintext flags:uint8 data:rawdata"),
    (816, "UamTxStatus", "seq:uint16 value:uint8 error:plaintext"),
    (817, "UamRxRange", "seq:uint16 sys:plaintext value:fp32"),
    (818, "UamTxRange", "seq:uint16 sys_dst:plaintext timeout:fp32"),
    (877, "MessagePart", "uid:uint8 frag_number:uint8 num_frags:uint8 data:rawdata"),
    (878, "MessagePartControl", "uid:uint8 op:uint8 frag_ids:plaintext"),
    (2010, "CommRestriction", "restriction:uint8 reason:plaintext"),
)

_specs = {}  # mgid -> (abbrev, spec string) not yet parsed
_ids = {}  # abbrev -> mgid
_parsed = {}  # mgid -> (mgid, abbrev, fields)


def _add(mgid, abbrev, spec):
    _specs[mgid] = (abbrev, spec)
    _ids[abbrev] = mgid
    _parsed.pop(mgid, None)


for _row in _TABLE:
    _add(_row[0], _row[1], _row[2])
_row = None


def _parse(abbrev, spec):
    fields = []
    seen = {}
    for item in spec.split():
        parts = item.split(":")
        name = parts[0]
        code = TYPE_CODES.get(parts[-1]) if len(parts) == 2 else None
        if code is None or not name or name in seen or name == "abbrev":
            raise ValueError("%s: bad field %r" % (abbrev, item))
        seen[name] = 1
        fields.append((name, code))
    return tuple(fields)


def define(mgid, abbrev, spec):
    # Adds (or replaces) a message: define(1001, "MyPing", "seq:uint16 note:plaintext").
    # The spec is checked now so a typo fails at start-up, not on first use.
    if not isinstance(mgid, int) or mgid < 0 or mgid >= 0xFFFF:
        raise ValueError("mgid must be 0..65534")
    old = _specs.get(mgid)
    if old is not None and _ids.get(old[0]) == mgid:
        del _ids[old[0]]
    fields = _parse(abbrev, spec)
    _add(mgid, abbrev, spec)
    _parsed[mgid] = (mgid, abbrev, fields)


def by_id(mgid):
    # (mgid, abbrev, fields) or None for an id acomm does not know.
    d = _parsed.get(mgid)
    if d is None:
        s = _specs.get(mgid)
        if s is None:
            return None
        d = _parsed[mgid] = (mgid, s[0], _parse(s[0], s[1]))
    return d


def by_name(abbrev):
    # (mgid, abbrev, fields); EncodeError for a name acomm does not know.
    mgid = _ids.get(abbrev) if isinstance(abbrev, str) else None
    if mgid is None:
        raise EncodeError("unknown IMC message %r" % (abbrev,))
    return by_id(mgid)


def known_ids():
    return sorted(_specs)
