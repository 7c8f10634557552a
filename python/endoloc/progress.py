"""Progress of long jobs: callables for the ``progress=`` argument.

A job calls ``progress(event, text, done, total)`` with ``event`` one of ``start`` (a loop of
``total`` steps labelled ``text`` begins), ``progress`` (``done`` of ``total`` steps),
``message`` (a short status such as the training loss), ``finish`` (the loop is over) and
``note`` (a line for the user: a stage that starts, a warning, where the results are). Calls
come while the job runs, from its worker threads, one at a time.
"""

from __future__ import annotations

import sys


class PrintProgress:
    """Notes and the end of each loop as lines on a stream (stderr by default)."""

    def __init__(self, stream=None):
        self.stream = stream if stream is not None else sys.stderr

    def __call__(self, event: str, text: str, done: int, total: int) -> None:
        if event == "note":
            print(text, file=self.stream, flush=True)
        elif event == "finish" and total:
            print(f"{text}: {done}/{total}", file=self.stream, flush=True)


class TqdmProgress:
    """One tqdm bar per loop of the job; notes through ``tqdm.write``. Needs ``tqdm``."""

    def __init__(self, **tqdm_options):
        from tqdm.auto import tqdm

        self._tqdm = tqdm
        self._options = tqdm_options
        self._bar = None

    def __call__(self, event: str, text: str, done: int, total: int) -> None:
        if event == "start":
            self._close()
            self._bar = self._tqdm(total=total or None, desc=text, **self._options)
        elif event == "progress" and self._bar is not None:
            if total and self._bar.total != total:
                self._bar.total = total
            self._bar.update(done - self._bar.n)
        elif event == "message" and self._bar is not None:
            self._bar.set_postfix_str(text)
        elif event == "finish":
            self._close()
        elif event == "note":
            self._tqdm.write(text)

    def _close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def default_progress():
    """``TqdmProgress`` when tqdm is installed, else ``PrintProgress``."""
    try:
        return TqdmProgress()
    except ImportError:
        return PrintProgress()
