"""Link health and link state as the window shows them: pure logic, no widgets.

Health is graded so it stays out of the way when all is well:

* ``ok``     -- no frame lost and no CRC failure within the last ``recent_s`` seconds: quiet grey;
* ``lossy``  -- frames lost or CRC failures within the last ``recent_s``: amber, with the rate;
* ``alert``  -- no data for ``no_data_alert_s`` (1 s) while connected, or the link is down: red.

"No data for N s" counts whole seconds from the engine's ``Snapshot.stalled_s`` (its one rule
for a stalled stream: ``gaitmon.engine.stream.STALL_AFTER_S``), in the status bar, the banner
and the banner of a link being reconnected alike, so N only grows until frames arrive.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gaitmon.engine.stream import STALL_AFTER_S

if TYPE_CHECKING:
    from gaitmon.engine import Snapshot

NO_DATA_ALERT_S = STALL_AFTER_S


def no_data_text(no_data_s: float) -> str:
    """ "no data for N s": whole seconds, counted up (N is 1 from the first second on)."""
    return f"no data for {max(int(no_data_s), 1)} s"


@dataclass(frozen=True)
class Health:
    grade: str  # ok | lossy | alert
    text: str  # one short line for the status bar
    tooltip: str


@dataclass(frozen=True)
class LinkView:
    """What the connection pill and the banner show."""

    state: str  # connected | reconnecting | lost | no data | disconnected
    pill: str  # short text of the state pill
    banner: str  # "" when no banner is needed; words a clinician reads, no library text
    grade: str  # ok | warn | alert (banner colour)
    tooltip: str = ""  # the technical reason, for whoever has to fix the link


def countdown_s(seconds: float | None) -> int | None:
    """Whole seconds to show for a wait (rounded up: "next in 1 s" until it happens), or None
    when the attempt is due or under way."""
    if seconds is None or seconds <= 0.05:
        return None
    return max(1, math.ceil(seconds - 1e-9))


class HealthTracker:
    """Keeps the recent history of the link counters to grade what happened lately."""

    def __init__(self, recent_s: float = 5.0, no_data_alert_s: float = NO_DATA_ALERT_S) -> None:
        self.recent_s = recent_s
        self.no_data_alert_s = no_data_alert_s
        self._hist: deque[tuple[float, int, int, int]] = deque()

    def reset(self) -> None:
        self._hist.clear()

    def update(
        self,
        now_s: float,
        frames_ok: int,
        frames_lost: int,
        crc_failures: int,
        frame_rate_hz: float,
        last_data_age_s: float,
        reconnects: int = 0,
        link_up: bool = True,
        errors: int = 0,
        last_error: str = "",
        implausible: int = 0,
    ) -> Health:
        """``errors``: blocks the engine could not read or process plus receive errors the
        device thread survived (never expected; shown amber with the last one in the tooltip)."""
        self._hist.append((now_s, frames_ok, frames_lost, crc_failures))
        while len(self._hist) > 2 and self._hist[1][0] <= now_s - self.recent_s:
            self._hist.popleft()
        _, ok0, lost0, crc0 = self._hist[0]
        d_ok, d_lost, d_crc = frames_ok - ok0, frames_lost - lost0, crc_failures - crc0
        rate = f"{frame_rate_hz:.0f} fps" if math.isfinite(frame_rate_hz) else "-- fps"
        totals = f"{frames_lost} lost · {crc_failures} CRC" + (
            f" · {implausible} implausible" if implausible else "")
        tip = (
            f"Link health. Frames received: {frames_ok}; lost (sequence gaps): {frames_lost}; "
            f"CRC failures (corrupted frames): {crc_failures}; implausible frames (passed the "
            f"CRC by chance, an impossible sequence jump; dropped): {implausible}; reconnects: "
            f"{reconnects}. Frame rate in frames per second (the unit sends 100)."
        )
        suffix = ""
        if errors:
            suffix = f" · {errors} error{'s' if errors != 1 else ''}"
            tip += f" Processing/receive errors: {errors}; last: {last_error}"
        if not link_up or last_data_age_s >= self.no_data_alert_s:
            what = no_data_text(last_data_age_s) if last_data_age_s > 0 else "link down"
            return Health("alert", f"{what} · {totals}{suffix}", tip)
        if d_lost > 0 or d_crc > 0:
            pct = 100.0 * d_lost / max(d_ok + d_lost, 1)
            window = f"{self.recent_s:g} s"
            text = f"{rate} · {pct:.1f} % lost, {d_crc} CRC in last {window}{suffix}"
            return Health("lossy", text, tip)
        return Health("lossy" if errors else "ok", f"{rate} · {totals}{suffix}", tip)


def link_view(
    link_state: str,
    link_reason: str,
    seconds_to_reconnect: float | None,
    last_data_age_s: float,
    port: str,
    no_data_alert_s: float = NO_DATA_ALERT_S,
    *,
    attempt: int = 1,
    device: str = "",
) -> LinkView:
    """The connection pill and banner for one snapshot of the engine.

    ``last_data_age_s``: seconds without data (the engine's ``Snapshot.stalled_s``; said once
    it reaches ``no_data_alert_s``, also while reconnecting). ``seconds_to_reconnect`` comes
    from the transport's next-attempt time at the moment of the snapshot, so the countdown is
    right at each refresh; ``attempt`` is the number of the attempt that countdown leads to
    (1 = the first after the loss). ``link_reason`` (the
    transport's one-line technical reason) goes to the tooltip only, after ``device`` (the
    port's real name, e.g. the simulator's pty path; default ``port``).
    """
    where = device or port
    tip = f"{where}: {link_reason}" if link_reason else where
    silent = last_data_age_s >= no_data_alert_s
    if link_state == "reconnecting":
        wait = countdown_s(seconds_to_reconnect)
        when = f"next in {wait} s" if wait is not None else "trying now"
        since = f"; {no_data_text(last_data_age_s)}" if silent else ""
        return LinkView(
            "reconnecting",
            f"Reconnecting ({wait} s)" if wait is not None else "Reconnecting…",
            f"Connection to the unit lost — reconnecting (attempt {max(attempt, 1)}, {when})"
            f"{since}. Recording and display resume by themselves.",
            "warn",
            tip,
        )
    if link_state == "failed":
        return LinkView(
            "lost",
            "Link lost",
            "Connection to the unit lost — gave up reconnecting. Check that the unit is on and "
            "within range, then connect again.",
            "alert",
            tip,
        )
    if link_state == "connected":
        if silent:
            return LinkView(
                "no data",
                "No data",
                f"No data from the unit for {max(int(last_data_age_s), 1)} s. Is it switched on "
                "and within range?",
                "alert",
                tip,
            )
        return LinkView("connected", "Connected", "", "ok")
    return LinkView("disconnected", "Disconnected", "", "ok")


def snapshot_link_view(snap: Snapshot, port: str) -> LinkView:
    """:func:`link_view` of one engine snapshot (with its link's next attempt and device)."""
    link = snap.link
    return link_view(
        snap.link_state,
        snap.link_reason,
        snap.seconds_to_reconnect,
        snap.stalled_s,
        port,
        attempt=link.transport.attempt + 1 if link is not None else 1,
        device=link.transport.port if link is not None else "",
    )


def snapshot_health(tracker: HealthTracker, snap: Snapshot, now_s: float) -> Health | None:
    """``tracker`` fed one snapshot's link counters (one unit, or one leg of two); None when
    the snapshot has no link (nothing to grade)."""
    link = snap.link
    if link is None:
        return None
    d = link.decoder
    return tracker.update(
        now_s,
        d.frames_ok,
        d.frames_lost + link.queue_overflow_frames,  # the receive queue's drops are gaps too
        d.crc_failures,
        snap.frame_rate_hz,
        snap.stalled_s,
        reconnects=link.reconnects,
        link_up=snap.link_state == "connected",
        errors=snap.engine_errors + link.rx_errors,
        last_error=snap.engine_error or link.rx_error,
        implausible=d.implausible_frames,
    )
