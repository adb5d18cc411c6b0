"""Link health and link state as the window shows them: pure logic, no widgets.

Health is graded so it stays out of the way when all is well:

* ``ok``     -- no frame lost and no CRC failure within the last ``recent_s`` seconds: quiet grey;
* ``lossy``  -- frames lost or CRC failures within the last ``recent_s``: amber, with the rate;
* ``alert``  -- no data for ``no_data_alert_s`` (2 s) while connected, or the link is down: red.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gaitmon.engine import Snapshot

NO_DATA_ALERT_S = 2.0


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
    ) -> Health:
        """``errors``: blocks the engine could not read or process plus receive errors the
        device thread survived (never expected; shown amber with the last one in the tooltip)."""
        self._hist.append((now_s, frames_ok, frames_lost, crc_failures))
        while len(self._hist) > 2 and self._hist[1][0] <= now_s - self.recent_s:
            self._hist.popleft()
        _, ok0, lost0, crc0 = self._hist[0]
        d_ok, d_lost, d_crc = frames_ok - ok0, frames_lost - lost0, crc_failures - crc0
        rate = f"{frame_rate_hz:.0f} fps" if math.isfinite(frame_rate_hz) else "-- fps"
        totals = f"{frames_lost} lost · {crc_failures} CRC"
        tip = (
            f"Link health. Frames received: {frames_ok}; lost (sequence gaps): {frames_lost}; "
            f"CRC failures (corrupted frames): {crc_failures}; reconnects: {reconnects}. "
            f"Frame rate in frames per second (the unit sends 100)."
        )
        suffix = ""
        if errors:
            suffix = f" · {errors} error{'s' if errors != 1 else ''}"
            tip += f" Processing/receive errors: {errors}; last: {last_error}"
        if not link_up or last_data_age_s >= self.no_data_alert_s:
            return Health("alert", f"no data for {last_data_age_s:.0f} s · {totals}{suffix}", tip)
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

    ``seconds_to_reconnect`` comes from the transport's next-attempt time at the moment of the
    snapshot, so the countdown is right at each refresh; ``attempt`` is the number of the
    attempt that countdown leads to (1 = the first after the loss). ``link_reason`` (the
    transport's one-line technical reason) goes to the tooltip only, after ``device`` (the
    port's real name, e.g. the simulator's pty path; default ``port``).
    """
    where = device or port
    tip = f"{where}: {link_reason}" if link_reason else where
    if link_state == "reconnecting":
        wait = countdown_s(seconds_to_reconnect)
        when = f"next in {wait} s" if wait is not None else "trying now"
        return LinkView(
            "reconnecting",
            f"Reconnecting ({wait} s)" if wait is not None else "Reconnecting…",
            f"Connection to the unit lost — reconnecting (attempt {max(attempt, 1)}, {when}). "
            "Recording and display resume by themselves.",
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
        if last_data_age_s >= no_data_alert_s:
            return LinkView(
                "no data",
                "No data",
                f"No data from the unit for {last_data_age_s:.0f} s. Is it switched on and "
                "within range?",
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
        snap.last_data_age_s,
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
        snap.last_data_age_s,
        reconnects=link.reconnects,
        link_up=snap.link_state == "connected",
        errors=snap.engine_errors + link.rx_errors,
        last_error=snap.engine_error or link.rx_error,
    )
