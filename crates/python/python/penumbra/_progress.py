"""The progress bar of ``penumbra.render``: tqdm when installed, else one
plain line on stderr redrawn in place."""

import sys
import time


class _Plain:
    def __init__(self):
        self.last = 0.0
        self.shown = False

    def update(self, done, total):
        now = time.monotonic()
        if now - self.last < 0.25 and done < total:
            return
        self.last = now
        pct = 100.0 * done / total if total else 100.0
        width = 30
        filled = int(width * done / total) if total else width
        sys.stderr.write("\rrendering [%s%s] %5.1f%%" % ("#" * filled, "." * (width - filled), pct))
        sys.stderr.flush()
        self.shown = True

    def close(self):
        if self.shown:
            sys.stderr.write("\n")
            sys.stderr.flush()


class _Tqdm:
    def __init__(self, tqdm):
        self.tqdm = tqdm
        self.bar = None

    def update(self, done, total):
        if self.bar is None:
            self.bar = self.tqdm(total=total, unit="samples", unit_scale=True, desc="rendering")
        self.bar.update(done - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def progress_bar():
    """A bar with ``update(done, total)`` and ``close()``."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _Plain()
    return _Tqdm(tqdm)
