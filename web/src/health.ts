// The firmware's health at a glance: its STATUS flags as readable badges (a stalled wheel, a
// closed bumper switch, a manual drive stopped by the timeout, default settings, a failed reset
// routine, a path still uploading…), each explained on a tap; and how fresh the live values are,
// so a quiet link or telemetry switched off shows as stale values with their age, not as a green
// dot beside frozen numbers.

import { age } from "./format";
import { flagDoc } from "./protocol";

type Tone = "ok" | "info" | "warn" | "bad";

/** Short words for each flag of docs/protocol.md (its meaning is shown on a tap). */
const FLAG_WORDS: Record<string, [string, Tone]> = {
  MOTORS_ENABLED: ["motors on", "ok"],
  SWITCH_LEFT: ["left switch pressed", "warn"],
  SWITCH_RIGHT: ["right switch pressed", "warn"],
  ARRIVED: ["arrived", "ok"],
  ROUTINE_FAILED: ["reset routine failed", "bad"],
  MANUAL_TIMEOUT: ["manual drive timed out", "info"],
  UPLOAD_OPEN: ["path upload open", "info"],
  SETTINGS_DEFAULTED: ["default settings (EEPROM)", "warn"],
  STALLED: ["stalled", "bad"],
  BUMPER: ["bumper hit", "bad"],
  POSE_RESTORED: ["pose restored from RAM", "info"],
  STARVED: ["starved of path points", "warn"],
};

/** A telemetry frame is late after this many of its intervals (and never before MIN_STALE_S). */
const LATE_INTERVALS = 3;
const MIN_STALE_S = 1;
const TICK_S = 0.008; // the firmware's control tick (docs/protocol.md, Telemetry)

export class FlagBadges {
  private shown = "";

  /** `bar`: the top bar's badges (what needs attention); `all`: every flag, in the map card. */
  constructor(
    private readonly bar: HTMLElement,
    private readonly all: HTMLElement,
    private readonly explain: (text: string) => void,
  ) {}

  show(flags: readonly string[]): void {
    const key = flags.join(" ");
    if (key === this.shown) return;
    this.shown = key;
    this.all.replaceChildren(...flags.map((f) => this.badge(f)));
    if (flags.length === 0) this.all.textContent = "no flags";
    this.bar.replaceChildren(...flags.filter((f) => (FLAG_WORDS[f]?.[1] ?? "warn") !== "ok").map((f) => this.badge(f)));
    this.bar.dataset["flags"] = key;
    this.all.dataset["flags"] = key;
  }

  private badge(flag: string): HTMLElement {
    const [words, tone] = FLAG_WORDS[flag] ?? [flag.toLowerCase().replaceAll("_", " "), "warn"];
    const meaning = flagDoc(flag)?.meaning ?? "";
    const b = document.createElement("button");
    b.type = "button";
    b.className = `badge badge-${tone}`;
    b.dataset["flag"] = flag;
    b.textContent = words;
    b.title = meaning ? `${flag}: ${meaning}` : flag;
    b.setAttribute("aria-label", `${words}: ${meaning || flag}`);
    b.addEventListener("click", () => this.explain(`${words} (${flag}): ${meaning || "a flag this panel does not know"}.`));
    return b;
  }
}

/** When the last telemetry frame arrived, and how often frames come (from their TICKs). */
export class TelemetryClock {
  private lastMs: number | null = null;
  private lastTick: number | null = null;
  private intervalS = 0.04;

  frame(tick: number): void {
    const now = performance.now();
    if (this.lastTick !== null) {
      const ticks = (tick - this.lastTick + 65536) % 65536;
      if (ticks > 0 && ticks < 32768) this.intervalS = ticks * TICK_S;
    }
    this.lastTick = tick;
    this.lastMs = now;
  }

  /** Seconds since the last frame; null before the first. */
  ageS(): number | null {
    return this.lastMs === null ? null : (performance.now() - this.lastMs) / 1000;
  }

  rateHz(): number {
    return 1 / this.intervalS;
  }

  stale(): boolean {
    const a = this.ageS();
    return a === null || a > Math.max(MIN_STALE_S, LATE_INTERVALS * this.intervalS);
  }

  /** "live, 25 Hz" or "stale: the last frame came 4.2 s ago". */
  words(): string {
    const a = this.ageS();
    if (a === null) return "no telemetry yet";
    return this.stale() ? `stale: the last frame came ${age(a)} ago` : `live, ${Math.round(this.rateHz())} Hz`;
  }
}
