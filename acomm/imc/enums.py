# Enumerations and bitfields of the IMC messages acomm speaks (ref/imc.md
# section 2), for code that builds or reads them: flags=UTF_ACK rather than
# flags=1. They travel as the field's integer type.

# UamTxFrame.flags
UTF_ACK = 0x01
UTF_DELAYED = 0x02
UTF_FORCED = 0x04

# UamRxFrame.flags
URF_PROMISCUOUS = 0x01
URF_DELAYED = 0x02

# UamTxStatus.value
UTS_DONE = 0
UTS_FAILED = 1
UTS_CANCELED = 2
UTS_BUSY = 3
UTS_INV_ADDR = 4
UTS_IP = 5
UTS_UNSUPPORTED = 6
UTS_INV_SIZE = 7
UTS_SENT = 8
UTS_DELIVERED = 9
UTS_NO_TRANSDUCER = 10

# TransmissionRequest.comm_mean
CMEAN_WIFI = 0
CMEAN_ACOUSTIC = 1
CMEAN_SATELLITE = 2
CMEAN_GSM = 3
CMEAN_ANY = 4
CMEAN_ALL = 5

# TransmissionRequest.data_mode
DMODE_INLINEMSG = 0
DMODE_TEXT = 1
DMODE_RAW = 2
DMODE_ABORT = 3
DMODE_RANGE = 4
DMODE_REVERSE_RANGE = 5

# TransmissionStatus.status
TSTAT_IN_PROGRESS = 0
TSTAT_SENT = 1
TSTAT_DELIVERED = 51
TSTAT_MAYBE_DELIVERED = 52
TSTAT_RANGE_RECEIVED = 60
TSTAT_INPUT_FAILURE = 101
TSTAT_TEMPORARY_FAILURE = 102
TSTAT_PERMANENT_FAILURE = 103
TSTAT_INV_ADDR = 104

# AnnounceService.service_type
SRV_TYPE_EXTERNAL = 0x01
SRV_TYPE_LOCAL = 0x02

# Announce.sys_type (SystemType)
SYSTEM_CCU = 0
SYSTEM_HUMANSENSOR = 1
SYSTEM_UUV = 2
SYSTEM_USV = 3
SYSTEM_UAV = 4
SYSTEM_UGV = 5
SYSTEM_STATICSENSOR = 6
SYSTEM_MOBILESENSOR = 7
SYSTEM_WSN = 8

# Addresses and entities (ref/imc.md 1.5)
ADDR_ANNOUNCE = 0x0000
ADDR_BROADCAST = 0xFFF0
ADDR_NULL = 0xFFFF  # in practice "to anyone"
ENTITY_UNKNOWN = 0xFF
