// Runs MicroPython's rp2 firmware on rp2040js 1.4.1 and puts the board's USB
// CDC REPL, UART0, UART1 and a control port on TCP. Started by
// ports/cpython/acomm_cpython/board/picoboard.py, which puts a pty in front of each.
//
//   node tools/rp2040/runner.mjs --firmware F.uf2|F.bin --bootrom rp2040-bootrom-b1.bin
//        [--flash IMAGE] [--host 127.0.0.1] [--usb-port N] [--uart0-port N] [--uart1-port N]
//        [--uart0-baud 115200] [--uart1-baud 19200] [--ctl-port N] [--speed-cap 1]
//
// Port 0 picks a free port. Prints one JSON line {"ready":true,"usb":..,"uart0":..,
// "uart1":..,"ctl":..} once all are bound, then runs until SIGTERM/SIGINT (saving
// the flash image first when --flash is given). The ctl port takes one command a
// line and answers one line: reset -> ok (power cycle: new chip, RAM cleared,
// flash kept; answered once done), save -> ok, time -> simulated ms, stats -> JSON
// counters, cpu -> JSON PC/LR/WFI state (to see where a stuck firmware waits).
// stats.sleep_ms is the simulated time the core spent in WFI/WFE since power-on (resets
// included): what is left of sim_ms is the time it ran, its CPU duty on a real chip.
// --speed-cap: simulated time never runs ahead of wall time times this (0: no cap).
import fs from 'node:fs';
import net from 'node:net';
import { performance } from 'node:perf_hooks';
import { RP2040, USBCDC, BasePeripheral } from 'rp2040js';

const FLASH_SIZE = 2 * 1024 * 1024; // a Pico's 2 MiB W25Q16
const FIRMWARE_REGION = 0xa0000; // RPI_PICO's littlefs starts at 0x100a0000
const BUF_LIMIT = 64 * 1024; // every per-channel buffer keeps at most this much
const USB_PACKET = 64; // full-speed bulk packet size
const LAG_SLACK_NS = 20e6; // how far simulated time may run ahead after lagging

// ---- arguments ----
const opts = { host: '127.0.0.1', 'usb-port': 0, 'uart0-port': 0, 'uart1-port': 0, 'ctl-port': 0,
  'uart0-baud': 115200, 'uart1-baud': 19200, 'speed-cap': 1, firmware: null, bootrom: null, flash: null };
for (let i = 2; i < process.argv.length; i += 2) {
  const key = process.argv[i].replace(/^--/, '');
  if (!(key in opts) || i + 1 >= process.argv.length) die(`bad option ${process.argv[i]}`);
  opts[key] = process.argv[i + 1];
}
if (!opts.firmware || !opts.bootrom) die('usage: runner.mjs --firmware FILE --bootrom FILE [--flash IMAGE] ...');
const speedCap = Number(opts['speed-cap']);
const bauds = [Number(opts['uart0-baud']), Number(opts['uart1-baud'])];

function die(msg) { process.stderr.write(`rp2040 runner: ${msg}\n`); process.exit(2); }

// uartN_rx_dropped: the 64 KiB input buffer overflowed; _rx_overrun: the 32-byte FIFO was
// full when a byte arrived; _rx_disabled: the UART was off (the byte is lost, as on a board)
const stats = { resets: 0, last_reset_ms: null, ctl_resets: 0, machine_resets: 0, watchdog_resets: 0,
  flash_erases: 0, flash_programs: 0, usb_in_bytes: 0, usb_in_dropped: 0, usb_out_bytes: 0, usb_out_dropped: 0,
  emulator_warnings: 0, emulator_errors: 0, sleep_ms: 0 };
let sleepNs = 0; // WFI/WFE time, in stats.sleep_ms when asked (a float add per wait, not per instruction)
for (const u of ['uart0', 'uart1']) {
  for (const k of ['rx_bytes', 'rx_dropped', 'rx_overrun', 'rx_disabled', 'tx_bytes', 'tx_dropped', 'fw_baud']) stats[`${u}_${k}`] = 0;
}

// ---- byte queues with a bound: past it the oldest bytes go, counted by onDrop ----
class ByteQueue {
  constructor(limit, onDrop) { this.buf = Buffer.alloc(0); this.limit = limit; this.onDrop = onDrop; }
  get length() { return this.buf.length; }
  push(data) {
    this.buf = Buffer.concat([this.buf, data]);
    const over = this.buf.length - this.limit;
    if (over > 0) { this.onDrop(over); this.buf = this.buf.subarray(over); }
  }
  take(n) { const out = this.buf.subarray(0, n); this.buf = this.buf.subarray(out.length); return out; }
  clear() { this.buf = Buffer.alloc(0); }
}

// ---- one TCP port per channel, one client at a time (a new one replaces the old) ----
class Channel {
  constructor(name, onData) {
    this.name = name; this.client = null; this.onData = onData;
    this.pending = new ByteQueue(BUF_LIMIT, (n) => { stats[`${name === 'usb' ? 'usb_out' : name + '_tx'}_dropped`] += n; });
    this.server = net.createServer((sock) => this.attach(sock));
  }
  attach(sock) {
    if (this.client) this.client.destroy();
    this.client = sock;
    sock.setNoDelay(true);
    sock.on('data', (d) => this.onData(d));
    sock.on('error', () => {});
    sock.on('close', () => { if (this.client === sock) this.client = null; });
    if (this.pending.length) sock.write(this.pending.take(this.pending.length));
  }
  send(bytes) {
    if (!this.client || !this.client.writable) this.pending.push(bytes); // kept (bounded) until a client connects
    else if (this.client.writableLength < BUF_LIMIT) this.client.write(bytes);
    else this.pending.onDrop(bytes.length); // a client that does not read: don't hoard
  }
}

function listen(server, port) {
  return new Promise((ok, fail) => {
    server.once('error', fail);
    server.listen(Number(port), opts.host, () => ok(server.address().port));
  });
}

// ---- images ----
function read(path) {
  try { return fs.readFileSync(path); } catch (e) { return die(`cannot read ${path}: ${e.message}`); }
}
const bootromBytes = new Uint8Array(read(opts.bootrom)); // own, aligned buffer
const bootrom = new Uint32Array(bootromBytes.buffer, bootromBytes.byteOffset, bootromBytes.length >> 2);
const romView = new DataView(bootromBytes.buffer, bootromBytes.byteOffset, bootromBytes.length);

function firmwareImage(path) { // [flash offset, bytes] pieces, from a UF2 or a .bin
  const data = read(path);
  if (data.length < 512 || data.readUInt32LE(0) !== 0x0a324655 || data.readUInt32LE(4) !== 0x9e5d5157) return [[0, data]];
  const pieces = [];
  for (let off = 0; off + 512 <= data.length; off += 512) {
    const flags = data.readUInt32LE(off + 8), addr = data.readUInt32LE(off + 12), size = data.readUInt32LE(off + 16);
    if (data.readUInt32LE(off) !== 0x0a324655 || flags & 1) continue; // not a block, or "not main flash"
    if (flags & 0x2000 && data.readUInt32LE(off + 28) !== 0xe48bff56) continue; // another chip's family
    pieces.push([addr - 0x10000000, data.subarray(off + 32, off + 32 + size)]);
  }
  return pieces;
}

let flash = new Uint8Array(FLASH_SIZE).fill(0xff);
if (opts.flash && fs.existsSync(opts.flash)) {
  flash.set(read(opts.flash).subarray(0, FLASH_SIZE));
  flash.fill(0xff, 0, FIRMWARE_REGION); // the firmware is replaced, the filesystem kept
}
for (const [off, bytes] of firmwareImage(opts.firmware)) {
  if (off < 0 || off + bytes.length > FLASH_SIZE) die(`firmware block at 0x${off.toString(16)} outside flash`);
  if (off + bytes.length > FIRMWARE_REGION) process.stderr.write('rp2040 runner: firmware runs into the filesystem region\n');
  flash.set(bytes, off);
}

function saveFlash() {
  if (!opts.flash) return;
  const f = chip ? chip.flash.subarray(0, FLASH_SIZE) : flash;
  fs.writeFileSync(opts.flash + '.tmp', f);
  fs.renameSync(opts.flash + '.tmp', opts.flash); // never a half-written image
}

// ---- behaviour 2: flash erase/program. The boot ROM's routines drive the SSI, which
// rp2040js only stubs, so they hang. pico-sdk finds them through the ROM function table
// (rom_func_lookup) and calls them from RAM with interrupts off; their first two
// halfwords become "BKPT #n; BX LR", the work is done below on the flash array and the
// BX LR returns to the caller. connect_internal_flash, flash_exit_xip, flash_flush_cache
// and the boot2 copy that re-enters XIP are left to run: on the stubbed SSI they finish.
const ROM_TRAPS = { RE: 0xe0, RP: 0xe1 };
function romFunc(code) {
  const want = code.charCodeAt(0) | (code.charCodeAt(1) << 8);
  for (let p = romView.getUint16(0x14, true); ; p += 4) {
    const c = romView.getUint16(p, true);
    if (!c) die(`boot ROM has no function ${code}`);
    if (c === want) return romView.getUint16(p + 2, true) & ~1;
  }
}
for (const [code, imm] of Object.entries(ROM_TRAPS)) {
  const at = romFunc(code);
  romView.setUint16(at, 0xbe00 | imm, true); // BKPT #imm
  romView.setUint16(at + 2, 0x4770, true); // BX LR
}

function onBreak(rp, code) {
  const r = rp.core.registers;
  if (code === ROM_TRAPS.RE) { // flash_range_erase(addr, count, block_size, block_cmd)
    const start = r[0] & ~0xfff, end = Math.min((r[0] + r[1] + 0xfff) & ~0xfff, FLASH_SIZE);
    if (start < end) rp.flash.fill(0xff, start, end);
    stats.flash_erases++;
  } else if (code === ROM_TRAPS.RP) { // flash_range_program(addr, data, count): NOR only clears bits
    for (let i = 0; i < r[2] && r[0] + i < FLASH_SIZE; i++) rp.flash[r[0] + i] &= rp.readUint8(r[1] + i);
    stats.flash_programs++;
  } else {
    // a panic()/hard_assert in the firmware: say where, then carry on past it as a NOP
    // (the firmware loops for ever after it, as it would on a board without a debugger)
    process.stderr.write(`rp2040 runner: BKPT #${code} at 0x${((rp.core.PC - 2) >>> 0).toString(16)}\n`);
  }
}

// ---- peripherals rp2040js lacks or gets wrong for MicroPython ----
// ROSC: pico_rand (os.urandom, random's seed) asserts ROSC_STATUS.ENABLED and samples
// RANDOMBIT; the stock UnimplementedPeripheral answers 0xffffffff (always bit 1) and logs.
class ROSC extends BasePeripheral {
  constructor(rp) { super(rp, 'ROSC'); this.regs = new Map(); }
  readUint32(off) {
    if (off === 0x18) return (1 << 31) | (1 << 12); // STATUS: STABLE | ENABLED
    if (off === 0x1c) return Math.random() < 0.5 ? 1 : 0; // RANDOMBIT
    return this.regs.get(off) ?? 0;
  }
  writeUint32(off, v) { this.regs.set(off, v); }
}
// WATCHDOG: rp2040js's own only calls an onWatchdogTrigger hook (by default it logs), and
// a reset here means a new chip, which must carry REASON and SCRATCH0-7 over (they
// survive a watchdog reset on the chip). This one counts down in simulated time and asks
// for the hard reset below. RP2040-E1: the counter ticks twice per microsecond, so
// pico-sdk writes LOAD = 2 x timeout_us, and a LOAD of n expires after n/2 us.
// TRIGGER (watchdog_reboot, i.e. machine.reset()) resets at once.
class Watchdog extends BasePeripheral {
  constructor(rp, carry) {
    super(rp, 'WATCHDOG');
    this.scratch = carry ? carry.scratch : new Uint32Array(8);
    this.reason = carry ? carry.reason : 0;
    this.ctrl = 0x07000000; this.tick = 0x200; this.load = 0; this.loadedAt = 0;
    this.alarm = rp.clock.createAlarm(() => requestReset('watchdog'));
  }
  get enabled() { return !!(this.ctrl & (1 << 30)); }
  remaining() { // counter value now, in E1 half-microsecond ticks
    if (!this.enabled) return this.load;
    return Math.max(0, Math.round(this.load - (this.rp2040.clock.nanos - this.loadedAt) / 500));
  }
  arm() {
    this.alarm.cancel();
    this.loadedAt = this.rp2040.clock.nanos;
    if (this.enabled) this.alarm.schedule(this.load * 500);
  }
  readUint32(off) {
    if (off === 0x00) return (this.ctrl & 0x47000000) | (this.remaining() & 0xffffff);
    if (off === 0x08) return this.reason;
    if (off >= 0x0c && off <= 0x28) return this.scratch[(off - 0x0c) >> 2];
    if (off === 0x2c) return this.tick | (this.tick & 0x200 ? 0x400 : 0); // RUNNING follows ENABLE
    return 0;
  }
  writeUint32(off, v) {
    if (off === 0x00) {
      if (v & (1 << 31)) return requestReset('machine');
      const was = this.enabled, left = this.remaining();
      this.ctrl = v & 0x47000000;
      if (this.enabled !== was) { this.load = left; this.arm(); } // the counter holds while disabled
    } else if (off === 0x04) {
      this.load = v & 0xffffff;
      this.arm();
    } else if (off >= 0x0c && off <= 0x28) this.scratch[(off - 0x0c) >> 2] = v;
    else if (off === 0x2c) this.tick = v & 0x3ff;
  }
}

// ---- the chip; a hard reset builds a new one around the same flash ----
let chip = null, cdc = null, usbRead = null, pendingReset = null, simBaseNs = 0;
let anchorSim = 0, anchorWall = 0, sleeper = null;
const afterReset = [];
// room for what one socket read brings (up to 64 KiB) past the point where the socket is paused
const usbIn = new ByteQueue(4 * BUF_LIMIT, (n) => { stats.usb_in_dropped += n; });
const uartIn = [0, 1].map((i) => new ByteQueue(BUF_LIMIT, (n) => { stats[`uart${i}_rx_dropped`] += n; }));
const uartAlarms = [null, null], uartOut = [[], []];
const logger = {
  // rp2040js logs every access to a register it does not model; count them, and show
  // them only with RP2040_RUNNER_DEBUG=1. Its errors would throw out of the CPU loop.
  debug() {}, info() {},
  warn(c, m) { stats.emulator_warnings++; if (process.env.RP2040_RUNNER_DEBUG) process.stderr.write(`[${c}] ${m}\n`); },
  error(c, m) { if (stats.emulator_errors++ < 20) process.stderr.write(`rp2040 runner: [${c}] ${m}\n`); },
};

const requestReset = (kind) => { pendingReset = pendingReset || kind; };

function powerOn(carry) {
  const rp = new RP2040();
  rp.logger = logger;
  rp.loadBootrom(bootrom); // the ROM's functions (table lookup, memcpy, flash) are used
  rp.flash.set(flash); // loadBootrom erased rp2040js's flash
  // Start at boot2 (the first 256 bytes of flash), as the ROM does after reading it
  // over QSPI: that read needs an SSI rp2040js does not model (the ROM would drop into
  // BOOTSEL mode). boot2 then enters XIP and jumps to the firmware's vector table.
  rp.core.PC = 0x10000000;
  rp.onBreak = (code) => onBreak(rp, code);
  rp.peripherals[0x40060] = new ROSC(rp);
  rp.peripherals[0x40058] = new Watchdog(rp, carry);
  rp.uart.forEach((u, i) => wireUart(rp, u, i));
  // GPIO_IN: rp2040js reads only levels driven from outside (none here), so an output
  // pin reads back 0 and so does a pulled-up input. Read the pad as a board would: the
  // driven level of an output, else its pull-up or pull-down.
  Object.defineProperty(rp, 'gpioValues', { get: () => rp.gpio.reduce((bits, p, i) => {
    const level = p.outputEnable ? p.outputValue : p.pullupEnabled || (!p.pulldownEnabled && p.rawInputValue);
    return level && p.inputEnable ? bits | (1 << i) : bits;
  }, 0) });
  // Core 1 is not emulated, nor SIO's inter-core FIFO (FIFO_ST 0x50, FIFO_WR 0x54,
  // FIFO_RD 0x58; rp2040js prints on each access). On every soft reset MicroPython's
  // mp_thread_deinit() calls multicore_reset_core1(), which powers core 1 off and on
  // through PSM FRCE_OFF and waits for the 0 that core 1's boot ROM then pushes to core
  // 0's FIFO: push that 0 here. Writes to core 1 go nowhere, so _thread cannot start.
  const fromCore1 = [];
  const psm = rp.peripherals[0x40010], psmWrite = psm.writeUint32.bind(psm);
  psm.writeUint32 = (off, v) => {
    const wasOff = psm.frceOff & (1 << 16);
    psmWrite(off, v);
    if (off === 4 && wasOff && !(psm.frceOff & (1 << 16))) fromCore1.push(0);
  };
  const sioRead = rp.sio.readUint32.bind(rp.sio), sioWrite = rp.sio.writeUint32.bind(rp.sio);
  rp.sio.readUint32 = (off) => (off === 0x50 ? 2 | (fromCore1.length ? 1 : 0) : off === 0x58 ? fromCore1.shift() ?? 0 : sioRead(off));
  rp.sio.writeUint32 = (off, v) => { if (off !== 0x54) sioWrite(off, v); };
  chip = rp;
  wireUsb(rp);
}

function wireUart(rp, u, i) {
  // Behaviour 1: rp2040js raises TXINTR on every interrupt check and never lets ICR clear
  // it, so MicroPython's UART handler runs for ever from the first machine.UART(). The
  // TX FIFO here empties at once, so raise TXINTR only when a byte has been written.
  u.checkInterrupts = () => rp.setInterrupt(u.irq, !!(u.interruptStatus & u.interruptMask));
  const write = u.writeUint32.bind(u);
  u.writeUint32 = (off, v) => {
    write(off, v);
    if (off === 0) { u.interruptStatus |= 1 << 5; u.checkInterrupts(); }
  };
  u.onByte = (b) => { stats[`uart${i}_tx_bytes`]++; uartOut[i].push(b); }; // sent after the slice
  u.onBaudRateChange = (baud) => { stats[`uart${i}_fw_baud`] = baud; };
  // Behaviour 4: the RX FIFO holds 32 bytes; feed one byte per character time
  // (10 bits at the line's baud) of simulated time, which runs slower than wall time.
  uartAlarms[i] = rp.clock.createAlarm(() => feedUart(u, i));
  if (uartIn[i].length) uartAlarms[i].schedule(1e10 / bauds[i]);
}

function feedUart(u, i) {
  if (!uartIn[i].length) return;
  const b = uartIn[i].take(1)[0];
  stats[`uart${i}_rx_bytes`]++;
  if (!(u.enabled && u.rxEnabled)) stats[`uart${i}_rx_disabled`]++;
  else if (u.rxFIFO.full) stats[`uart${i}_rx_overrun`]++;
  else u.feedByte(b);
  if (uartIn[i].length) uartAlarms[i].schedule(1e10 / bauds[i]);
}

function uartInput(i, data) {
  if (!uartIn[i].length) uartAlarms[i].schedule(1e10 / bauds[i]); // the line was idle: start it
  uartIn[i].push(data);
}

function wireUsb(rp) {
  // USBCDC enumerates the device (and sets DTR, so MicroPython sends its output).
  cdc = new USBCDC(rp.usbCtrl);
  usbRead = null;
  cdc.onSerialData = (buf) => { stats.usb_out_bytes += buf.length; channels.usb.send(Buffer.from(buf)); };
  // Behaviour 3: USBCDC answers every OUT buffer at once from a 512-byte FIFO (more is
  // dropped), with empty packets when it has nothing. Here the buffer MicroPython arms
  // is held until there is input, then filled with at most one 64-byte packet; the
  // rest waits in usbIn. Holding it also lets an idle REPL sleep in WFE.
  rp.usbCtrl.onEndpointRead = (ep, size) => {
    if (ep !== cdc.outEndpoint) return;
    usbRead = { ep, size };
    pumpUsb();
  };
}

function pumpUsb() {
  if (!usbRead || !usbIn.length || !chip) return;
  const bytes = usbIn.take(Math.min(usbRead.size, USB_PACKET));
  stats.usb_in_bytes += bytes.length;
  chip.usbCtrl.endpointReadDone(usbRead.ep, bytes);
  usbRead = null;
  const c = channels.usb.client;
  if (c && c.isPaused() && usbIn.length < BUF_LIMIT / 4) c.resume();
}

function hardReset(kind) {
  stats.resets++;
  stats[`${kind}_resets`]++;
  simBaseNs += chip.clock.nanos;
  stats.last_reset_ms = simBaseNs / 1e6;
  flash = chip.flash.slice(0, FLASH_SIZE);
  const wd = chip.peripherals[0x40058];
  // ctl reset = power cycle: watchdog state gone; watchdog/machine.reset keep it
  const carry = kind === 'ctl' ? null : { scratch: wd.scratch, reason: kind === 'watchdog' ? 1 : 2 };
  usbIn.clear(); // what the host sent the old chip is lost with its USB session
  powerOn(carry);
  anchorSim = 0; anchorWall = performance.now();
  while (afterReset.length) afterReset.shift()();
}

function simNs() { return simBaseNs + (chip ? chip.clock.nanos : 0); }

// ---- the CPU loop: slices of ~15 ms wall, yielding to Node's event loop between ----
function run() {
  sleeper = null;
  const rp = chip, core = rp.core, clock = rp.clock;
  const nsPerCycle = 1e9 / rp.clkSys;
  const now = performance.now();
  let cap = speedCap > 0 ? anchorSim + (now - anchorWall) * 1e6 * speedCap : Infinity;
  if (cap - clock.nanos > LAG_SLACK_NS) { // lagging (busy CPU): don't race to catch up later
    anchorSim = clock.nanos; anchorWall = now - LAG_SLACK_NS / 1e6 / speedCap;
    cap = clock.nanos + LAG_SLACK_NS;
  }
  const sliceEnd = now + 15;
  let idle = false;
  slice: while (!pendingReset) {
    for (let i = 0; i < 20000; i++) {
      if (core.waiting) {
        // WFI/WFE: jump to the next timer event, but not past wall time (the
        // firmware's timeouts must mean the same to programs on the TCP side)
        const next = clock.nextAlarm ? clock.nanos + clock.nanosToNextAlarm : Infinity;
        if (next > cap || next === Infinity) { // nothing due before the cap, or at all
          if (cap !== Infinity && cap > clock.nanos) { sleepNs += cap - clock.nanos; clock.tick(cap - clock.nanos); }
          idle = true;
          break slice;
        }
        sleepNs += next - clock.nanos;
        clock.tick(next - clock.nanos);
      } else {
        clock.tick(core.executeInstruction() * nsPerCycle);
      }
      if (pendingReset) break slice;
    }
    if (clock.nanos > cap) { idle = true; break; }
    if (performance.now() > sliceEnd) break;
  }
  uartOut.forEach((out, i) => { if (out.length) channels[`uart${i}`].send(Buffer.from(out.splice(0))); });
  if (pendingReset) { const k = pendingReset; pendingReset = null; hardReset(k); }
  if (idle) sleeper = setTimeout(run, 1);
  else setImmediate(run);
}

function wake() { // input arrived: don't leave it waiting for the idle timer
  if (sleeper) { clearTimeout(sleeper); sleeper = null; setImmediate(run); }
}

// ---- control port ----
function ctlCommand(line, reply) {
  const cmd = line.trim();
  if (cmd === 'reset') { afterReset.push(() => reply('ok')); requestReset('ctl'); }
  else if (cmd === 'save') { try { saveFlash(); reply(opts.flash ? 'ok' : 'error no --flash image'); } catch (e) { reply(`error ${e.message}`); } }
  else if (cmd === 'time') reply((simNs() / 1e6).toFixed(3));
  else if (cmd === 'stats') reply(JSON.stringify({ ...stats, sleep_ms: sleepNs / 1e6, sim_ms: simNs() / 1e6, wall_ms: performance.now() - startWall }));
  else if (cmd === 'cpu') reply(JSON.stringify({ pc: chip.core.PC, lr: chip.core.LR, waiting: chip.core.waiting, primask: chip.core.PM, ipsr: chip.core.IPSR }));
  else if (cmd) reply(`error unknown command ${JSON.stringify(cmd)} (reset, save, time, stats, cpu)`);
}

const channels = {
  // USB has flow control (the device NAKs what it cannot take): past half the queue the
  // client's socket is paused, so TCP holds the rest back instead of bytes being dropped
  usb: new Channel('usb', (d) => {
    usbIn.push(d); pumpUsb(); wake();
    if (usbIn.length >= BUF_LIMIT / 2 && channels.usb.client) channels.usb.client.pause();
  }),
  uart0: new Channel('uart0', (d) => { uartInput(0, d); wake(); }),
  uart1: new Channel('uart1', (d) => { uartInput(1, d); wake(); }),
};
const ctl = net.createServer((sock) => {
  let buf = '';
  sock.on('error', () => {});
  sock.on('data', (d) => {
    buf += d.toString();
    let nl;
    while ((nl = buf.indexOf('\n')) >= 0) {
      const line = buf.slice(0, nl); buf = buf.slice(nl + 1);
      ctlCommand(line, (msg) => { if (sock.writable) sock.write(msg + '\n'); });
    }
  });
});

function shutdown() {
  try { saveFlash(); } catch (e) { process.stderr.write(`rp2040 runner: saving flash: ${e.message}\n`); }
  process.exit(0);
}
process.on('SIGTERM', shutdown);
process.on('SIGINT', shutdown);

const startWall = performance.now();
powerOn(null);
const ports = {};
try {
  for (const name of ['usb', 'uart0', 'uart1']) ports[name] = await listen(channels[name].server, opts[`${name}-port`]);
  ports.ctl = await listen(ctl, opts['ctl-port']);
} catch (e) {
  die(`cannot listen: ${e.message}`);
}
process.stdout.write(JSON.stringify({ ready: true, ...ports }) + '\n');
anchorWall = performance.now();
run();
