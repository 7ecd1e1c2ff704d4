#!/usr/bin/env python3
"""Writes the synthetic fuzz seeds (tests/fuzz/seeds/<target>/). No real data is copied; the HDD
seed takes the first lines of the committed HDD test fixture."""
import struct, random, os
random.seed(1)
os.chdir(os.path.dirname(os.path.abspath(__file__)))
for t in "nmea can drive_csv openxc hdd comma2k19 template_blob replay_input detector dsp logs asc ubx profile".split():
    os.makedirs("seeds/" + t, exist_ok=True)
def ck(b):
    c = 0
    for ch in b: c ^= ord(ch)
    return "%02X" % c
def nmea(lat, lon, spd, crs, t):
    def dm(d, w):
        a = abs(d); D = int(a); return "%0*d%09.6f" % (w, D, (a - D) * 60)
    hms = "%02d%02d%05.2f" % (t // 3600 % 24, t // 60 % 60, t % 60)
    ns, ew = ('N' if lat >= 0 else 'S'), ('E' if lon >= 0 else 'W')
    gga = "GPGGA,%s,%s,%s,%s,%s,1,12,0.8,10.0,M,0.0,M,," % (hms, dm(lat, 2), ns, dm(lon, 3), ew)
    rmc = "GPRMC,%s,A,%s,%s,%s,%s,%.3f,%.2f,020818,,,A" % (hms, dm(lat, 2), ns, dm(lon, 3), ew, spd / 0.514444, crs)
    vtg = "GPVTG,%.2f,T,,M,%.3f,N,%.3f,K,A" % (crs, spd / 0.514444, spd * 3.6)
    return "".join("$%s*%s\r\n" % (s, ck(s)) for s in (gga, vtg, rmc))
lat, lon = 48.137, 11.575
lines = ""
for k in range(20):
    lat += 0.00005; lon += 0.00003
    lines += nmea(lat, lon, 8.0 + k * 0.1, 23.0, 3600 + k * 0.1)
open("seeds/nmea/gga_vtg_rmc", "w").write(lines)
open("seeds/nmea/no_fix", "w").write("$GPRMC,,V,,,,,,,,,,N*53\r\n$GPGGA,,,,,,0,,,,,,,,*66\r\n")
ids = [0xB4, 0x25, 0x2C1, 0x24, 0x228]
b = b""
for k in range(60):
    b += struct.pack("<HB", ids[k % 5], 8) + bytes(random.randrange(256) for _ in range(8))
open("seeds/can/profile_frames", "wb").write(b)
hdr = "t_s,unix_time_s,lat_deg,lon_deg,gnss_new_fix,gnss_fix_age_s,gnss_speed_mps,gnss_course_deg,veh_speed_mps,steer_wheel_deg,accel_pedal_pct,long_accel_mps2,yaw_rate_degps\n"
rows = ""
lat, lon = 48.137, 11.575
for k in range(40):
    t = k * 0.1; nf = 1 if k % 10 == 0 else 0
    if nf: lat += 0.00008
    rows += "%.1f,%d,%.7f,%.7f,%d,%.2f,%.2f,%.1f,%.2f,%.1f,%.1f,%.2f,%.2f\n" % (t, 1600000000 + int(t), lat, lon, nf, (k % 10) * 0.1, 9.0, 0.0, 9.0 + random.random() * 0.1, random.uniform(-5, 5), 20.0, 0.1, 0.0)
open("seeds/drive_csv/synthetic", "w").write(hdr + rows)
open("seeds/drive_csv/minimal", "w").write("t_s,lat_deg,lon_deg,gnss_new_fix,veh_speed_mps\n0,48.0,11.0,1,1.0\n1,48.0001,11.0,1,\n")
o = ""; t = 1332794185.0
for k in range(40):
    t += 0.1
    nm = ["vehicle_speed", "steering_wheel_angle", "accelerator_pedal_position", "latitude", "longitude", "engine_speed"][k % 6]
    v = {"latitude": 42.29 + k * 1e-5, "longitude": -83.23 - k * 1e-5}.get(nm, random.uniform(0, 60))
    o += '%.6f: {"name":"%s","value":%f}\n' % (t, nm, v)
o += '%.6f: {"name":"door_status","value":"driver"}\n' % (t + 0.1)
open("seeds/openxc/synthetic", "w").write(o)
fx = "../../host-sim/tests/fixtures/hdd/201702271017/general/csv/"
a = "".join(open(fx + "rtk_pos.csv").readlines()[:15]); v = "".join(open(fx + "vel.csv").readlines()[:15])
open("seeds/hdd/fixture_head", "wb").write(a.encode() + b"\xff" + v.encode())
t = b"".join(struct.pack("<d", x * 0.1) for x in range(10))
val = b"".join(struct.pack("<6d", 48.0 + x * 1e-5, 11.0, 5.0, 0, 0, 10.0) for x in range(10))
open("seeds/comma2k19/ten_fixes", "wb").write(b"\x01" + t[1:] + b"\xff" + val)
open("seeds/template_blob/twenty", "wb").write(open("../../detector-core/models/turn_templates.bin", "rb").read()[:14 + 66 * 20] + b"\0\0\0\0")
can = b"".join(struct.pack("<IHB", k * 10000, ids[k % 5], 8) + bytes(8) for k in range(3))
nmb = b""
for s, tu in [("$GPRMC,000000.00,A,4808.22000,N,01134.50000,E,10.0,90.0,020818,,,A", 0), ("$GPRMC,000000.10,A,4808.22010,N,01134.50100,E,10.0,90.0,020818,,,A", 100000)]:
    s = s + "*" + ck(s[1:]); nmb += struct.pack("<IB", tu, len(s)) + s.encode()
off = 20 + 32 + len(can)
h = b"GGQI" + struct.pack("<HHId", 1, 1, 3, 0.0) + b"clean".ljust(16, b"\0") + struct.pack("<dII", float("nan"), off, 2)
open("seeds/replay_input/minimal", "wb").write(h + can + nmb)
open("seeds/detector/random", "wb").write(bytes(random.randrange(256) for _ in range(24 * 30)))
# dsp: a shape byte, activations, weights; extremes (0x80 weights, i16::MIN activations) too.
open("seeds/dsp/random", "wb").write(bytes(random.randrange(256) for _ in range(1 + 96 + 600)))
open("seeds/dsp/extremes", "wb").write(bytes([47]) + b"\x00\x80" * 48 + b"\x80" * 600)
# logs: a few candump lines of the RAV4 ids (standard, extended, remote, FD), 0xFF, NMEA with host timestamps.
can_lines = "(1.000000) can0 0B4#0000000000123400\n(1.010000) can0 025#0FFF000000000000\n(1.020000) can1 18FEF100#0102\n(1.030000) can0 123#R\n(1.040000) can0 224##1" + "00" * 12 + "\n"
gnss_lines = "".join("(%.6f) %s\n" % (1.0 + k * 0.1, s) for k in range(5) for s in nmea(48.137 + k * 1e-5, 11.575, 10.0, 90.0, 3600 + k * 0.1).split("\r\n") if s)
open("seeds/logs/rav4", "wb").write(can_lines.encode() + b"\xff" + gnss_lines.encode())
# asc: every kind of line (standard, extended, remote, CAN FD, error frame, statistics), and relative decimal time.
open("seeds/asc/kinds", "w").write("date Thu Aug 2 08:34:47.250 am 2018\nbase hex  timestamps absolute\ninternal events logged\n"
    "Begin Triggerblock Thu Aug 2 08:34:47.250 am 2018\n   0.000000 Start of measurement\n"
    "   0.012345 1  0B4             Rx   d 8 00 00 00 00 00 12 34 00\n   0.020000 2  18FEF100x       Rx   d 3 01 02 03\n"
    "   0.030000 1  123  Tx   r\n   0.035000 1  ErrorFrame\n   0.036000 1  Statistic: D 0 R 0\n"
    "   0.040000 CANFD   1 Rx 123  Name  1 0 c 12 00 01 02 03 04 05 06 07 08 09 0a 0b\nEnd TriggerBlock\n")
open("seeds/asc/relative", "w").write("date Thu Aug 2 20:34:47 2018\nbase dec  timestamps relative\n0.5 1 180 Rx d 1 255\n0.25 1 180 Rx d 1 1\n")
# ubx: NAV-PVT (3D fix) + NAV-STATUS (spoofing indicated) framed, an NMEA sentence between, a long frame skipped.
def ubx_frame(cls, mid, payload):
    body = bytes([cls, mid]) + struct.pack("<H", len(payload)) + payload
    a = b = 0
    for x in body:
        a = (a + x) & 255; b = (b + a) & 255
    return b"\xb5\x62" + body + bytes([a, b])
pvt = bytearray(92)
struct.pack_into("<IHBBBBBB", pvt, 0, 123456000, 2018, 8, 2, 8, 34, 47, 7)
struct.pack_into("<i", pvt, 16, 250000000)
pvt[20] = 3; pvt[21] = 1; pvt[23] = 12
struct.pack_into("<iiiiII", pvt, 24, -1224723053, 377209977, 0, 0, 1500, 2000)
struct.pack_into("<iiIIi", pvt, 60, 7823, 214000, 300, 150000, 0)
status = bytearray(16); status[4] = 3; status[5] = 13; status[7] = 2 << 3
open("seeds/ubx/pvt_status", "wb").write(ubx_frame(1, 7, bytes(pvt)) + b"$GPGGA,1*00\r\n" + ubx_frame(1, 3, bytes(status)) + ubx_frame(10, 4, bytes(120)))
# profile: a small DBC (standard, extended, multiplexed, signed, both byte orders), a map, frames.
dbc = """VERSION ""

BO_ 180 SPEED: 8 XXX
 SG_ SPEED : 47|16@0+ (0.01,0) [0|250] "kph" XXX
BO_ 2566844672 EXT: 8 XXX
 SG_ YAW : 0|16@1- (0.01,0) [-300|300] "deg/s" XXX
BO_ 37 MUXED: 8 XXX
 SG_ MUX M : 0|8@1+ (1,0) [0|255] "" XXX
 SG_ ANGLE m1 : 8|16@1- (0.1,0) [-600|600] "deg" XXX
 SG_ PEDAL m2 : 8|8@1+ (0.5,0) [0|100] "%" XXX
"""
mp = "SPEED.SPEED wheel_speed 1/3.6\nEXT.YAW yaw_rate -1\nMUXED.ANGLE steering 1.0 bus=0\nMUXED.PEDAL pedal 1\n"
open("seeds/profile/mixed", "wb").write(dbc.encode() + b"\xff" + mp.encode() + b"\xff" + bytes(random.randrange(256) for _ in range(90)))

# calibration: GGCR records (a 1 Hz car without gyro, a 10 Hz car with one), a damaged copy of
# each (a flipped bit, a cut), and a store's flash image holding one of them.
import zlib
os.makedirs("seeds/calibration", exist_ok=True)
# Version 3 carries the car's anchors (scale, two delays, gyro scale error) and its noise's
# anchors (s0, k, velocity noise, two each); version 2 (without the noise's) and version 1
# (without any) are still read.
def ggcr(scale, dpos, dvel, learnt, drives, bias, bias_w, gse, gsd, s0, k, vs, dt, anchors=None, noise_anchors=None):
    p = struct.pack("<ffffHHffff2f2f2ff", scale, dpos, dvel, learnt, drives, 0, bias, bias_w, gse, gsd, *s0, *k, *vs, dt)
    if anchors is not None:
        p += struct.pack("<4f", *anchors)
    if noise_anchors is not None:
        p += struct.pack("<6f", *noise_anchors)
    version = 1 if anchors is None else 2 if noise_anchors is None else 3
    b = b"GGCR" + struct.pack("<HH", version, len(p)) + p
    return b + struct.pack("<I", zlib.crc32(b))
nan = float("nan")
recs = {"no_gyro_1hz": ggcr(1.004, -0.75, nan, 9000.0, 4, nan, 0.0, 0.0, 0.05, (1.6, 2.1), (0.012, 0.011), (0.25, 0.4), 1.0, (0.998, -0.5, nan, 0.0), (1.4, 2.0, 0.01, 0.01, 0.22, 0.35)),
        "gyro_10hz": ggcr(0.991, 0.125, 0.25, 600.0, 1, 0.39, 40.0, -0.01, 0.004, (1.0, 1.2), (0.01, 0.01), (0.12, 0.18), 0.1, (0.991, 0.125, 0.25, -0.02), (1.0, 1.2, 0.01, 0.01, 0.12, 0.18)),
        "version2": ggcr(1.004, -0.75, nan, 9000.0, 4, nan, 0.0, 0.0, 0.05, (1.6, 2.1), (0.012, 0.011), (0.25, 0.4), 1.0, (0.998, -0.5, nan, 0.0)),
        "version1": ggcr(1.004, -0.75, nan, 9000.0, 4, nan, 0.0, 0.0, 0.05, (1.6, 2.1), (0.012, 0.011), (0.25, 0.4), 1.0)}
for name, b in recs.items():
    open("seeds/calibration/" + name, "wb").write(b)
    d = bytearray(b); d[13] ^= 0x40
    open("seeds/calibration/" + name + "_flipped", "wb").write(bytes(d))
    open("seeds/calibration/" + name + "_cut", "wb").write(b[:40])
open("seeds/calibration/empty_flash", "wb").write(b"\xff" * 64)
