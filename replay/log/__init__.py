"""Reading a log: every byte from an untrusted file stops here.

- :mod:`replay.log.mcap_records`: single MCAP records parsed with every length bounded;
  :mod:`replay.log.mcap_scan`: one pass over the data section (with resync for
  ``--recover``); :mod:`replay.log.mcap_summary`: the footer and the CRC-checked summary,
  compared with the data; :mod:`replay.log.catalogue`: all of it checked, shared by
  the reader and ``dsp-info``;
- :mod:`replay.log.reader`: :class:`LogReader`, the log's messages in log-time order and its
  typed metadata; :mod:`replay.log.messages`: the validated records it yields;
  :mod:`replay.log.schemas`: a log's ROS 2 definitions checked against the contract's;
- :mod:`replay.log.recovery`: what ``--recover`` lost; :mod:`replay.log.decode`: image
  messages to pixels, sized from the header first (:mod:`replay.log.raw_image`: every raw
  ROS 2 colour and grey encoding).

It imports nothing of replay but its errors (:mod:`replay.errors`): no sink, no option.
"""

from __future__ import annotations

from replay.log.catalogue import Catalogue, build_catalogue, check_mcap_file, read_all_blocks
from replay.log.decode import DEFAULT_MAX_PIXELS, decode_image, image_problem, image_size
from replay.log.mcap_records import DEFAULT_MAX_CHUNK_BYTES, DEFAULT_MAX_MESSAGE_BYTES, Limits
from replay.log.messages import BadMessage, ImageMessage, PoseMessage, TruthMessage
from replay.log.reader import LogInfo, LogReader
from replay.log.recovery import RecoveryLoss

__all__ = [
    "DEFAULT_MAX_CHUNK_BYTES",
    "DEFAULT_MAX_MESSAGE_BYTES",
    "DEFAULT_MAX_PIXELS",
    "BadMessage",
    "Catalogue",
    "ImageMessage",
    "Limits",
    "LogInfo",
    "LogReader",
    "PoseMessage",
    "RecoveryLoss",
    "TruthMessage",
    "build_catalogue",
    "check_mcap_file",
    "decode_image",
    "image_problem",
    "image_size",
    "read_all_blocks",
]
