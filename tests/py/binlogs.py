#!/usr/bin/env python3
"""Independent writers and readers of binary CAN logs, for tests/tests/binlogs.rs: python-can
(BLF, and MF4 through asammdf) and asammdf itself.

Subcommands (frames as JSON lines: {"t": unix s, "bus": n, "id": n, "ext": bool, "data": hex}):
  random-frames SEED N           N random frames: buses 0-3, standard and extended ids, CAN and
                                 CAN FD payloads (0 to 64 bytes), increasing times
  write-blf FRAMES OUT           python-can's BLFWriter (channel = bus + 1)
  read-blf IN                    python-can's BLFReader: the data frames (error frames left out)
  candump-to-blf IN OUT          a candump log through python-can's reader into its BLFWriter
  write-mf4 FRAMES OUT LEVEL     python-can's MF4Writer (asammdf; BusChannel = bus + 1),
                                 compression 0 (none), 1 (deflate) or 2 (transposed deflate)
  unfinalise IN OUT              a copy of a finalised MF4 as a logger leaves it when power is cut:
                                 `UnFinMF `, cycle counts not updated (0), flags saying so
  asammdf-counts FILE...         frames per (BusChannel, ID) of every CAN_DataFrame group, as
                                 asammdf reads them
"""
import json
import random
import struct
import sys


def frames_in(path):
    with open(path) as f:
        return [json.loads(l) for l in f if l.strip()]


def emit(t, bus, can_id, ext, data):
    print(json.dumps({"t": t, "bus": bus, "id": can_id, "ext": ext, "data": bytes(data).hex()}))


def random_frames(seed, n):
    rng = random.Random(seed)
    t = 1_700_000_000.0 + rng.random()
    for _ in range(n):
        t += rng.choice([0.0001, 0.00025, 0.001, 0.0123])
        ext = rng.random() < 0.4
        can_id = rng.randrange(0x2000_0000) if ext else rng.randrange(0x800)
        fd = rng.random() < 0.3
        size = rng.choice([0, 1, 8, 12, 16, 20, 24, 32, 48, 64]) if fd else rng.randrange(9)
        emit(round(t, 6), rng.randrange(4), can_id, ext, [rng.randrange(256) for _ in range(size)])


def message(f, can):
    data = bytes.fromhex(f["data"])
    return can.Message(timestamp=f["t"], arbitration_id=f["id"], is_extended_id=f["ext"], channel=f["bus"], data=data,
                       dlc=len(data), is_fd=len(data) > 8 or f.get("fd", False), is_rx=True)


def write_blf(frames_path, out):
    import can
    with can.BLFWriter(out) as w:
        for f in frames_in(frames_path):
            w.on_message_received(message(f, can))


def read_blf(path):
    import can
    for m in can.BLFReader(path):
        if m.is_error_frame:
            continue
        emit(m.timestamp, m.channel, m.arbitration_id, m.is_extended_id, b"" if m.is_remote_frame else m.data)


def candump_to_blf(src, out):
    import can
    with can.BLFWriter(out) as w:
        for m in can.CanutilsLogReader(src):
            w.on_message_received(m)


def write_mf4(frames_path, out, level):
    import can
    frames = frames_in(frames_path)
    w = can.MF4Writer(out, compression_level=int(level))
    for f in frames:
        m = message(f, can)
        m.channel = f["bus"] + 1
        w.on_message_received(m)
    w.stop()


def unfinalise(src, out):
    b = bytearray(open(src, "rb").read())
    assert b[:8] == b"MDF     ", "expected a finalised MDF 4 file"
    b[:8] = b"UnFinMF "
    # id_unfin_flags (offset 60): bit 0 = cycle counters of CG/CA blocks not updated.
    struct.pack_into("<H", b, 60, 0x1)
    # Every channel group's cycle count (cg_cycle_count: 24-byte header, 6 links, record id) to 0.
    pos = 0
    while True:
        pos = b.find(b"##CG", pos)
        if pos < 0:
            break
        links = struct.unpack_from("<Q", b, pos + 16)[0]
        struct.pack_into("<Q", b, pos + 24 + 8 * links + 8, 0)
        pos += 4
    open(out, "wb").write(bytes(b))


def asammdf_counts(paths):
    import asammdf
    counts = {}
    for p in paths:
        m = asammdf.MDF(p)
        try:
            ids = m.get("CAN_DataFrame.ID").samples
            bus = m.get("CAN_DataFrame.BusChannel").samples
        except Exception:  # a file without data frames
            continue
        for b, i in zip(bus.tolist(), ids.tolist()):
            k = f"{b}:{i & 0x1FFFFFFF}"
            counts[k] = counts.get(k, 0) + 1
    print(json.dumps(counts, sort_keys=True))


def main():
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "random-frames":
        random_frames(int(args[0]), int(args[1]))
    elif cmd == "write-blf":
        write_blf(*args)
    elif cmd == "read-blf":
        read_blf(args[0])
    elif cmd == "candump-to-blf":
        candump_to_blf(*args)
    elif cmd == "write-mf4":
        write_mf4(*args)
    elif cmd == "unfinalise":
        unfinalise(*args)
    elif cmd == "asammdf-counts":
        asammdf_counts(args)
    else:
        sys.exit(f"unknown subcommand {cmd}")


main()
