"""The QoS a recording offers for a topic (:class:`~topojax.io.mcap.McapRecorder`)."""

from __future__ import annotations


def offered_qos(latched: bool) -> list:
    """The offered QoS of a topic: reliable, transient local, depth 1 for a ``latched``
    one; the default (none recorded) for the others."""
    if not latched:
        return []
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    zero = QosTime(0, 0)
    return [
        Qos(
            QosHistory.KEEP_LAST,
            1,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL,
            zero,
            zero,
            QosLiveliness.AUTOMATIC,
            zero,
            False,
        )
    ]
