# A TEST KEY, not Rock7's: the RSA key (2048 bits, made once with
# `openssl genrsa`) with which the emulated RockBLOCK service signs its MO
# POSTs (acomm_cpython.emulate.rockblockgw). Its private half is public
# here, so a JWT it signs proves nothing outside tests: a shore node uses
# Rock7's published key (shore.rock7_key) unless told otherwise. `acomm emulate iridium
# --rockblock-public-key PATH` writes the public half for a shore under test.

PRIVATE_PEM = """\
-----BEGIN RSA PRIVATE KEY-----
MIIEowIBAAKCAQEAms/oCg5Unv9DhAlxaJWHVyFYSaK0+e/U679ecau2SZ1gKGAc
ImwJnmmQa3OkwxK54LcxDEcJ8Z96+mOkcD2RPhLxKonqZokFZ0hCQRIV+3GcKE/g
7y/vaZmZcwXN6pZVUksUJ9ICSQFWckY6NEzQwK8bHWSR5LbCAHIh+NpfqY0I86ds
ECFDM/vLKfpP3IZ/MvEJecI+AG2rIftiIU/Fn4vYS0YE3bMKx/6NtEKJOb+47S75
Ck5I0bfxbDqWQFt/9F8X5xERl2Th/zX8Jz//7cP6CbfXc8fo5pBmciDetLPvgqZ9
tY5uxcV++dbheKpTqE8zye5EkbbCK+cNqbQ4/QIDAQABAoIBAAGPR7t0Vk5ytPx+
ff6KaYTJVoyA+DYQryrfzExSekkBcjnCtZbruVN8C7dewMK6odXYJMVK5SDilz3K
SZqgapDa3d3OyAhxfTk/Srhjgf24qF1MaDBE+10JQ2OTI+3RpNlY/8JzvmVZoUzL
1SHAsSrIVJQA1Ldz12CFgZQ/MAq9xpgTKTKRsX+lWz8+wSz9LdkXSnkSi6clniHd
o+5Shxjy6UGeslTpAQPbG7gmZKr74Oqeb4FYKwdKGCcp7zSH38FCs5o1GHzE7yt4
41Q4IRjbA2QpiT5tb0mkkADHKRTwMk2s3Z4pyV/FqmZGOs7on2sFjD+Rp/+92auo
JN3H7AECgYEA0j2Vp80TcIAKny7HaWtw8hOFBNFAduf52FbmLfpDBbb1sZ3Mht3v
lDudgLgLMAEGDMR2ly2ZtNUL94HcDoJm6GOdJjFDsabecMeSdGHfXUXB6vVRzAFU
+6RAq7NcsD4FJ+9CjhAEJlV6InIQqD5ri8Ah8elFJSMXnlO8GQZXfNECgYEAvIHm
QxL+LzyoS7JBNkG/dm0/oAUP3jg34G9BRqycOZkFyYWVUtR+Ktd/Z/K2TsMPN36U
nKymrqpz8mWhimerYftVW4q6IgIRUnSeNIY1N5LFEKPbrV+68l9sP3+bjQeOm7w+
DvABxwHUcfS2gG/reZHiEFVF057PL9+8VFtn1G0CgYEAkTiy6C6yz9HSBHSWj84E
PWKYTmSQB9Ji9TnJU1b79rWTbvXV8g7ZT2YCfIgkSita13TZicGY250R4AxWSbtv
g/RS96+t18ew/OwN0NBOLqphsX902drNreieNzv0uVSN0TDmoySTCTuf2q05rk03
klfL2sLL3UQpK1chpZOI2RECgYBwXtL/auQBDpyYOxNqn3jdxLQn1Lyn0EVm0YtM
8PpTz2dGwQ3JiYgIS9vUADgy7U4124wFdVoLRurFNVY9phzg1K0GW8UnHqpqx7/D
ObmhfilhCPyb9jP/5Wgm1g/I2xdkuKsZxnKYyft1TtY36/+nwZHMALkWNFX3iNzA
QJi9ZQKBgBXIqnq/Y6RiYpnF8ky925yBZrhxe276qex5Nz6dlXQOzQ+ZcfDZWenw
LfNCY1vVKm1/gy4Hc4cV6P6YJOAeNxmRZz31oOx94jY0DDrddXTSZcKucDKwj9EC
y+HEAk/DwljzoEiCam5Fgtv9Sv27qUJWUbCAORaDPS7PPg86P9jy
-----END RSA PRIVATE KEY-----
"""
