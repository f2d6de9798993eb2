"""A sweep stops once: the first Ctrl-C or SIGTERM stops it, later ones go unheard."""

from __future__ import annotations

import os
import signal

import pytest

from hubero_dsl.errors import Terminated
from hubero_dsl.sweep.executors import stopped_once


@pytest.mark.parametrize(("received", "raised"), [(signal.SIGINT, KeyboardInterrupt),
                                                  (signal.SIGTERM, Terminated)])
def test_the_first_stop_is_raised_and_the_next_go_unheard(received: int,
                                                          raised: type[BaseException]) -> None:
    before = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    heard_after_the_first = []
    with stopped_once():
        with pytest.raises(raised) as stop:
            os.kill(os.getpid(), received)
        assert type(stop.value) is raised
        for again in (signal.SIGINT, signal.SIGTERM, received):
            os.kill(os.getpid(), again)  # a second press while the sweep is stopping
            heard_after_the_first.append(again)
    assert len(heard_after_the_first) == 3
    assert {number: signal.getsignal(number) for number in before} == before


def test_a_stop_lost_in_a_callback_and_sent_again_is_heard() -> None:
    with stopped_once():
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
        signal.getsignal(signal.SIGINT).rearm()  # type: ignore[union-attr]
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
