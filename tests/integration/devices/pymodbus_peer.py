#!/usr/bin/python3
"""An independent Modbus peer (pymodbus, Debian's python3-pymodbus) for the driver tests.

server: serves a turntable register map (JSON from paintlab's RegisterMap::to_json) over
        Modbus TCP on 127.0.0.1 or RTU on a serial device. A start/home command moves the
        table to its target; the status word shows the move for a few status reads first.
client: drives a server (paintlab's simulated controller) through the same map: writes a
        move, polls the status until in position, reads the encoder, and probes an
        unmapped register. Prints one JSON line.

Run with the system interpreter (/usr/bin/python3), which has Debian's pymodbus.
"""
import argparse
import json
import logging
import sys
import time


def field_regs(m, f, value):
    """Register values of `value` in field f (1 or 2 words, map's word order)."""
    v = value & 0xFFFFFFFF
    if f["words"] == 1:
        return [v & 0xFFFF]
    hi, lo = v >> 16, v & 0xFFFF
    return [hi, lo] if m["word_order"] == "high-first" else [lo, hi]


def field_value(m, f, regs):
    if f["words"] == 1:
        v = regs[0]
        return v - 0x10000 if f["signed"] and v >= 0x8000 else v
    hi, lo = (regs[0], regs[1]) if m["word_order"] == "high-first" else (regs[1], regs[0])
    v = (hi << 16) | lo
    return v - 0x100000000 if f["signed"] and v >= 0x80000000 else v


def all_addresses(m):
    out = set()
    for key, f in m.items():
        if isinstance(f, dict) and "address" in f:
            for i in range(f["words"]):
                out.add(f["address"] + i)
    return sorted(out)


def run_server(args, m):
    from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
    from pymodbus.server import StartSerialServer, StartTcpServer
    from pymodbus.transaction import ModbusRtuFramer

    addrs = all_addresses(m)
    first, last = addrs[0], addrs[-1]
    st = m["status"]

    class Table(ModbusSequentialDataBlock):
        """Registers plus a controller that moves when start/home is written."""

        def __init__(self):
            super().__init__(first, [0] * (last - first + 1))
            self.busy_reads = 0
            self.target = 0
            self.homed = False
            self.homing = False
            self.put_status(moving=False)

        def raw_set(self, f, value):
            super(Table, self).setValues(f["address"], field_regs(m, f, value))

        def raw_get(self, f):
            return field_value(m, f, super(Table, self).getValues(f["address"], f["words"]))

        def put_status(self, moving):
            word = 0
            if st["ready_bit"] >= 0 and not moving:
                word |= 1 << st["ready_bit"]
            if st["in_position_bit"] >= 0 and not moving:
                word |= 1 << st["in_position_bit"]
            if st["homed_bit"] >= 0 and self.homed and not moving:
                word |= 1 << st["homed_bit"]
            if moving:
                word |= st["moving_mask"]
            self.raw_set(st, word)

        def validate(self, address, count=1):
            return all(a in addrs for a in range(address, address + count))

        def getValues(self, address, count=1):
            if address <= st["address"] < address + count:
                if self.busy_reads > 0:
                    self.busy_reads -= 1
                    self.put_status(moving=True)
                else:
                    self.raw_set(m["encoder_position"], self.target)
                    if self.homing:
                        self.homed, self.homing = True, False
                    self.put_status(moving=False)
            return super().getValues(address, count)

        def setValues(self, address, values):
            super().setValues(address, values)
            end = address + len(values)
            for name in ("start", "home", "stop"):
                a = m.get(name)
                if not a or not (a["address"] < end and address < a["address"] + a["words"]):
                    continue
                v = self.raw_get(a)
                if (v & a["value"]) != a["value"]:
                    continue
                if name == "start":
                    self.target = self.raw_get(m["target_position"])
                    self.busy_reads = 3
                    self.homing = False
                elif name == "home":
                    self.target, self.busy_reads, self.homing = 0, 3, True
                else:
                    self.busy_reads = 0
                if not a["pulse"] and a["address"] != st["address"]:
                    self.raw_set(a, 0)

    block = Table()
    slave = ModbusSlaveContext(hr=block, zero_mode=True)
    context = ModbusServerContext(slaves={args.unit: slave}, single=False)
    print("ready", flush=True)
    if args.tcp is not None:
        StartTcpServer(context=context, address=("127.0.0.1", args.tcp))
    else:
        StartSerialServer(context=context, framer=ModbusRtuFramer, port=args.rtu, baudrate=115200,
                          bytesize=8, parity="N", stopbits=1, timeout=0.05)


def run_client(args, m):
    from pymodbus.client import ModbusSerialClient, ModbusTcpClient

    if args.tcp is not None:
        client = ModbusTcpClient("127.0.0.1", port=args.tcp, timeout=2)
    else:
        client = ModbusSerialClient(args.rtu, baudrate=115200, parity="N", bytesize=8, stopbits=1, timeout=1)
    if not client.connect():
        print(json.dumps({"error": "cannot connect"}))
        return 1

    def write(f, value):
        rr = client.write_registers(f["address"], field_regs(m, f, value), slave=args.unit)
        if rr.isError():
            raise RuntimeError("write 0x%04X: %s" % (f["address"], rr))

    def read(f):
        rr = client.read_holding_registers(f["address"], f["words"], slave=args.unit)
        if rr.isError():
            raise RuntimeError("read 0x%04X: %s" % (f["address"], rr))
        return field_value(m, f, rr.registers)

    if m.get("operation_type"):
        write(m["operation_type"], m["op_absolute"])
    write(m["target_position"], args.target_counts)
    write(m["speed"], args.speed)
    for key in ("acceleration", "deceleration"):
        if m.get(key):
            write(m[key], args.accel)
    a = m["start"]
    write(a, a["value"])
    if a["pulse"]:
        write(a, 0)
    st = m["status"]
    polls, saw_moving, word = 0, False, 0
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        word = read(st)
        polls += 1
        moving = (word & st["moving_mask"]) != 0
        saw_moving = saw_moving or moving
        in_pos = ((word >> st["in_position_bit"]) & 1) if st["in_position_bit"] >= 0 else not moving
        if in_pos and not moving:
            break
        time.sleep(0.01)
    encoder = read(m["encoder_position"])
    # A register outside the map: the server must answer exception 2 (illegal data address).
    rr = client.read_holding_registers(0xFFF0, 1, slave=args.unit)
    exc = getattr(rr, "exception_code", None) if rr.isError() else None
    client.close()
    print(json.dumps({"encoder": encoder, "polls": polls, "saw_moving": saw_moving, "status": word,
                      "unmapped_exception": exc}))
    return 0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("mode", choices=["server", "client"])
    p.add_argument("--map", required=True, help="register map JSON (RegisterMap::to_json)")
    p.add_argument("--tcp", type=int, help="TCP port on 127.0.0.1")
    p.add_argument("--rtu", help="serial device (RTU, 115200 8N1)")
    p.add_argument("--unit", type=int, default=1)
    p.add_argument("--target-counts", type=int, default=0)
    p.add_argument("--speed", type=int, default=1000)
    p.add_argument("--accel", type=int, default=10000)
    args = p.parse_args()
    if (args.tcp is None) == (args.rtu is None):
        p.error("give exactly one of --tcp and --rtu")
    logging.basicConfig(level=logging.ERROR)
    with open(args.map) as f:
        m = json.load(f)
    if args.mode == "server":
        run_server(args, m)
        return 0
    return run_client(args, m)


if __name__ == "__main__":
    sys.exit(main())
