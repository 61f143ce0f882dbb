# acomm_web: the operator console in a browser (docs/console.md). server.py
# is portable (CPython and MicroPython, on microdot); host.py runs it in a
# thread beside a CPython node loop; page.html is the whole page, shipped
# with its gzip (page.html.gz, made by `python -m acomm_web.page`).
