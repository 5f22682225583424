// The telemetry recorded while the page is open: every frame with its firmware time (TICK × 8 ms,
// docs/protocol.md: no network jitter) and the time it arrived (an absolute timestamp), and the
// ground truth of a simulator beside it. What the plots draw and the CSV export holds.

import type { Telemetry, Truth } from "./api";

const TICK_S = 0.008;
const CAPACITY = 50 * 120; // two minutes at the firmware's fastest telemetry rate
const TRUTH_CAPACITY = 2 * CAPACITY;

export interface Range {
  from: number; // firmware time, s
  to: number;
}

export class TelemetryRecord {
  readonly t: number[] = []; // firmware time since the first frame, s
  readonly wallMs: number[] = []; // when each frame arrived (ms since the epoch)
  readonly frames: Telemetry[] = [];
  readonly truth: { wallMs: number; x: number; y: number }[] = [];
  private lastTick: number | null = null;
  private lastWallMs = 0;

  add(frame: Telemetry, wallMs = Date.now()): void {
    const last = this.t[this.t.length - 1];
    let t = 0;
    if (last !== undefined && this.lastTick !== null) {
      const ticks = (frame.tick - this.lastTick + 65536) % 65536;
      // TICK wraps every 524 s; backwards (more than half a wrap) is a restarted controller,
      // whose time is not comparable: carried on by the time between the arrivals instead.
      t = last + (ticks < 32768 ? ticks * TICK_S : Math.max(TICK_S, (wallMs - this.lastWallMs) / 1000));
    }
    this.lastTick = frame.tick;
    this.lastWallMs = wallMs;
    this.t.push(t);
    this.wallMs.push(wallMs);
    this.frames.push(frame);
    if (this.t.length > CAPACITY) {
      const extra = this.t.length - CAPACITY;
      this.t.splice(0, extra);
      this.wallMs.splice(0, extra);
      this.frames.splice(0, extra);
    }
  }

  addTruth(truth: Truth, wallMs = Date.now()): void {
    this.truth.push({ wallMs, x: truth.x, y: truth.y });
    if (this.truth.length > TRUTH_CAPACITY) this.truth.splice(0, this.truth.length - TRUTH_CAPACITY);
  }

  /** Forgets everything (a replay that jumped to another time). */
  clear(): void {
    for (const list of [this.t, this.wallMs, this.frames, this.truth]) list.length = 0;
    this.lastTick = null;
  }

  get lastT(): number {
    return this.t[this.t.length - 1] ?? 0;
  }

  get firstT(): number {
    return this.t[0] ?? 0;
  }

  /** The index range [start, end) of the frames within `r`. */
  indices(r: Range): [number, number] {
    let start = 0;
    while (start < this.t.length && (this.t[start] ?? 0) < r.from) start++;
    let end = start;
    while (end < this.t.length && (this.t[end] ?? 0) <= r.to) end++;
    return [start, end];
  }

  /** The frames within `r` (everything recorded without), as CSV: `t_s` the firmware's time
   * (TICK × 8 ms, from the first frame recorded), `time_utc` when the frame arrived, then every
   * telemetry field (tick included). */
  csv(r?: Range): string {
    const [start, end] = r ? this.indices(r) : [0, this.frames.length];
    const first = this.frames[start];
    if (!first || end <= start) return "";
    const fields = (Object.keys(first) as (keyof Telemetry)[]).filter((k) => k !== "type");
    const cell = (v: unknown): string => {
      const text = Array.isArray(v) ? v.join(" ") : String(v);
      return /[",\n]/.test(text) ? `"${text.replaceAll('"', '""')}"` : text;
    };
    const lines = [["t_s", "time_utc", ...fields].join(",")];
    for (let k = start; k < end; k++) {
      const frame = this.frames[k];
      if (!frame) continue;
      const when = new Date(this.wallMs[k] ?? 0).toISOString();
      lines.push([(this.t[k] ?? 0).toFixed(3), when, ...fields.map((f) => cell(frame[f]))].join(","));
    }
    return lines.join("\n") + "\n";
  }
}
