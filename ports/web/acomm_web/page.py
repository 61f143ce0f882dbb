# The page's gzip, shipped beside it so that a board serves it compressed
# without compressing anything: `python -m acomm_web.page` writes
# page.html.gz again after page.html changed (a test checks they agree).
import gzip
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def sizes():
    """(raw bytes, gzipped bytes) of the page as shipped."""
    return (os.path.getsize(os.path.join(HERE, "page.html")), os.path.getsize(os.path.join(HERE, "page.html.gz")))


def compressed():
    """page.html gzipped, byte for byte the same on every run (no time stamp)."""
    with open(os.path.join(HERE, "page.html"), "rb") as f:
        return gzip.compress(f.read(), 9, mtime=0)


def main():
    with open(os.path.join(HERE, "page.html.gz"), "wb") as f:
        f.write(compressed())
    print("page.html: %d B, gzipped %d B" % sizes())


if __name__ == "__main__":
    main()
