# Rock7's (Ground Control's) public key, the one the RockBLOCK web service
# signs each MO POST's JWT with (RS256): the default key of a RockBLOCK
# shore (shore.spec; `key=PEM` overrides it, e.g. for the emulator's TEST
# key). A published fact, not a secret: Ground Control's documentation
# page "Receiving MO messages via HTTP Webhook",
# https://docs.groundcontrol.com/iot/rockblock/web-services/receiving-mo-message
# (read 2026-11-27), section "JSON Web Token". If Rock7 changes its key,
# this text changes with it (or give key= until a release does).

PUBLIC_PEM = """\
-----BEGIN PUBLIC KEY-----
MIIBIjANBgkqhkiG9w0BAQEFAAOCAQ8AMIIBCgKCAQEAlaWAVJfNWC4XfnRx96p9
cztBcdQV6l8aKmzAlZdpEcQR6MSPzlgvihaUHNJgKm8t5ShR3jcDXIOI7er30cIN
4/9aVFMe0LWZClUGgCSLc3rrMD4FzgOJ4ibD8scVyER/sirRzf5/dswJedEiMte1
ElMQy2M6IWBACry9u12kIqG0HrhaQOzc6Tr8pHUWTKft3xwGpxCkV+K1N+9HCKFc
cbwb8okRP6FFAMm5sBbw4yAu39IVvcSL43Tucaa79FzOmfGs5mMvQfvO1ua7cOLK
fAwkhxEjirC0/RYX7Wio5yL6jmykAHJqFG2HT0uyjjrQWMtoGgwv9cIcI7xbsDX6
owIDAQAB
-----END PUBLIC KEY-----
"""
SOURCE = "https://docs.groundcontrol.com/iot/rockblock/web-services/receiving-mo-message"
