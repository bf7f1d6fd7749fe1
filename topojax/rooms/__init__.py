"""Rooms and doorways: a region graph on top of the topology graph."""

from .links import assign_rooms
from .model import Door, LoadedRooms, Room, RoomSegmentation
from .segment import RoomConfig, segment_rooms

__all__ = [
    "Door",
    "LoadedRooms",
    "Room",
    "RoomConfig",
    "RoomSegmentation",
    "assign_rooms",
    "segment_rooms",
]
