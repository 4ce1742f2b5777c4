#!/usr/bin/python3
"""A gauge amplifier served by pymodbus, with a register map unlike gaugeloop's simulator.

Holding registers (function 03), 0-based:
  10-11  reading, float32 mm, word order CDAB
  12     angle, uint16, 0.01 deg
  13     status: 0x8000 ready, 0x0100 over-range, 0x0200 under-range, 0x0400 probe missing
  14-15  sample number, uint32, word order DCBA
  (examples/gauges/other_amplifier.toml reads no revolution count: the client counts the
  angle wrapping; the two registers below are for maps that ask for them)
  16     revolution count, uint16, moving --revolution-lag-deg after the angle wraps (own cycle)
  17     status code: 0 ok; bit 5 coil open (from --fault-at-rev on)
  500-501 latch count, uint32 CDAB; ring of 400 entries from 2000, 3 registers each:
          degree uint16, then the reading float32 CDAB.

The lobe: lift_mm(deg) below. Usage: pymodbus_gauge.py [speed_rpm] [--revolution-lag-deg D]
[--fault-at-rev R] [--freeze-at-rev R] [--degrees-per-read D] (revolutions from the start; a
freeze stops every register, the sample number too). With --degrees-per-read the spindle's
clock is the reads, not the wall clock: each read of the angle register turns it D degrees
(the sample number and time follow at speed_rpm), so a client slowed by a loaded machine
still sees every degree. Prints "port N" once listening on 127.0.0.1 (port chosen by the
system); serves until its stdin closes.
"""
import argparse
import asyncio
import logging
import math
import struct
import sys
import time

from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.server.async_io import ModbusTcpServer

ARGS = argparse.ArgumentParser()
ARGS.add_argument("speed_rpm", type=float, nargs="?", default=60.0)
ARGS.add_argument("--revolution-lag-deg", type=float, default=0.0)
ARGS.add_argument("--fault-at-rev", type=float, default=None)
ARGS.add_argument("--freeze-at-rev", type=float, default=None)
ARGS.add_argument("--degrees-per-read", type=float, default=None)
OPTS = ARGS.parse_args()
SPEED_RPM = OPTS.speed_rpm
RING = 400
COIL_OPEN = 0x0020


def lift_mm(deg):
    """The reading at a machine degree; the test knows the same formula."""
    rad = math.radians(deg)
    return 2.0 + 1.5 * math.cos(rad) + 0.2 * math.sin(3.0 * rad)


def float_cdab(value):
    hi, lo = struct.unpack(">HH", struct.pack(">f", value))
    return [lo, hi]


def u32_cdab(value):
    return [value & 0xFFFF, (value >> 16) & 0xFFFF]


def swap(word):
    return ((word << 8) | (word >> 8)) & 0xFFFF


def u32_dcba(value):
    return [swap(value & 0xFFFF), swap((value >> 16) & 0xFFFF)]


class Gauge(ModbusSequentialDataBlock):
    """Registers computed from the clock whenever a client reads them."""

    def __init__(self):
        super().__init__(0, [0] * 4000)
        self.t0 = time.monotonic()
        self.reads = 0
        self.latched = 0

    def getValues(self, address, count=1):
        if OPTS.degrees_per_read is not None and address <= 12 < address + count:
            self.reads += 1
        self.update()
        return super().getValues(address, count)

    def update(self):
        if OPTS.degrees_per_read is None:
            t = time.monotonic() - self.t0
        else:
            t = self.reads * OPTS.degrees_per_read / 360.0 * 60.0 / SPEED_RPM
        turns = t * SPEED_RPM / 60.0
        if OPTS.freeze_at_rev is not None and turns >= OPTS.freeze_at_rev:
            return  # frozen: the registers keep their last values
        faulted = OPTS.fault_at_rev is not None and turns >= OPTS.fault_at_rev
        deg = (turns * 360.0) % 360.0
        v = self.values
        v[10:12] = float_cdab(lift_mm(deg))
        v[12] = int(deg * 100.0) % 36000
        v[13] = 0x8000
        v[14:16] = u32_dcba(int(t * 1e6) & 0xFFFFFFFF)
        v[16] = int(math.floor(turns - OPTS.revolution_lag_deg / 360.0)) & 0xFFFF
        v[17] = COIL_OPEN if faulted else 0
        marks = int(turns * 360.0) + 1
        for i in range(max(self.latched, marks - RING), marks):
            at = 2000 + 3 * (i % RING)
            v[at] = i % 360
            v[at + 1 : at + 3] = float_cdab(lift_mm(i % 360))
        self.latched = max(self.latched, marks)
        v[500:502] = u32_cdab(self.latched & 0xFFFFFFFF)


async def main():
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # it logs closed sessions as errors
    context = ModbusServerContext(slaves=ModbusSlaveContext(hr=Gauge(), zero_mode=True), single=True)
    server = ModbusTcpServer(context, address=("127.0.0.1", 0), allow_reuse_address=True)
    task = asyncio.create_task(server.serve_forever())
    await server.serving
    print(f"port {server.server.sockets[0].getsockname()[1]}", flush=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    await server.server_close()
    task.cancel()


asyncio.run(main())
