// Manual driving: the arrow keys or W A S D held down, the on-screen buttons held (by pointer, or
// focused and held with Space or Enter: a deadman button, released means stop), or the joystick.
// While anything is held, POST /api/drive every 150 ms (the gateway stops the cart without one
// for 0.5 s); on release one last (0, 0). A focused slider or radio group keeps its arrow keys.

import { api } from "./api";
import { byId } from "./dom";
import { Joystick, type Stick } from "./joystick";
import type { PanelContext } from "./tuning";

type Dir = "fwd" | "back" | "left" | "right";

const KEYS: Record<string, Dir> = {
  ArrowUp: "fwd",
  KeyW: "fwd",
  ArrowDown: "back",
  KeyS: "back",
  ArrowLeft: "left",
  KeyA: "left",
  ArrowRight: "right",
  KeyD: "right",
};
const REPEAT_MS = 150;

/** Whether a key pressed in `target` belongs to it: text typed into a field, or an arrow key
 * moving a slider or a radio group's choice. */
function ownsKey(target: EventTarget | null, code: string): boolean {
  if (target instanceof HTMLSelectElement || target instanceof HTMLTextAreaElement) return true;
  if (!(target instanceof HTMLInputElement)) return false;
  if (target.type === "range" || target.type === "radio") return code.startsWith("Arrow");
  return true;
}

export class Driver {
  private readonly held = new Set<Dir>();
  private readonly speed = byId<HTMLInputElement>("drive-speed");
  private timer: number | null = null;
  private inFlight = false;
  private pending: [number, number] | null = null; // asked for while one was in flight
  private stick: Stick = null;
  private readonly joystick: Joystick;

  constructor(
    private readonly ctx: PanelContext,
    private readonly limits: () => { vMax: number; wMax: number },
  ) {
    this.speed.addEventListener("input", () => this.showSpeed());
    this.showSpeed();
    this.joystick = new Joystick(byId("joystick"), byId("joystick-knob"), (s) => {
      const first = this.stick === null && s !== null;
      this.stick = s;
      if (first) this.start(); // then every 150 ms while held; the tick after release stops
    });
    window.addEventListener("keydown", (e) => {
      const dir = KEYS[e.code];
      if (!dir || e.ctrlKey || e.altKey || e.metaKey || ownsKey(e.target, e.code)) return;
      e.preventDefault();
      if (!e.repeat) this.press(dir);
    });
    window.addEventListener("keyup", (e) => {
      const dir = KEYS[e.code];
      if (dir) this.release(dir);
    });
    window.addEventListener("blur", () => this.releaseAll());
    for (const button of document.querySelectorAll<HTMLButtonElement>("[data-drive]")) this.wire(button);
  }

  /** Lets go of everything held (an emergency stop, the window losing focus). */
  releaseAll(): void {
    this.held.clear();
    for (const b of document.querySelectorAll<HTMLButtonElement>("[data-drive]")) b.setAttribute("aria-pressed", "false");
    this.joystick.release();
  }

  private showSpeed(): void {
    byId("drive-speed-out").textContent = `${Number(this.speed.value).toFixed(2)} m/s`;
  }

  private wire(button: HTMLButtonElement): void {
    const dir = button.dataset["drive"] as Dir;
    const down = (): void => {
      button.setAttribute("aria-pressed", "true");
      this.press(dir);
    };
    const up = (): void => {
      button.setAttribute("aria-pressed", "false");
      this.release(dir);
    };
    button.setAttribute("aria-pressed", "false");
    button.addEventListener("pointerdown", (e) => {
      button.setPointerCapture(e.pointerId);
      down();
    });
    for (const end of ["pointerup", "pointercancel", "lostpointercapture"] as const) button.addEventListener(end, up);
    button.addEventListener("contextmenu", (e) => e.preventDefault());
    // The keyboard's deadman: Space or Enter held on the focused button drives, released stops.
    // No click follows (a button clicks on Space's release, Enter's press).
    button.addEventListener("keydown", (e) => {
      if (e.key !== " " && e.key !== "Enter") return;
      e.preventDefault();
      if (!e.repeat) down();
    });
    button.addEventListener("keyup", (e) => {
      if (e.key !== " " && e.key !== "Enter") return;
      e.preventDefault();
      up();
    });
    button.addEventListener("blur", up);
  }

  private press(dir: Dir): void {
    this.held.add(dir);
    this.start();
  }

  private release(dir: Dir): void {
    this.held.delete(dir);
  }

  private start(): void {
    if (this.timer === null) {
      this.tick();
      this.timer = window.setInterval(() => this.tick(), REPEAT_MS);
    }
  }

  private tick(): void {
    if (this.held.size === 0 && this.stick === null) {
      if (this.timer !== null) window.clearInterval(this.timer);
      this.timer = null;
      void this.send(0, 0);
      return;
    }
    const round = (x: number): number => Math.round(x * 1000) / 1000;
    if (this.stick) {
      // the firmware's max speeds scaled by the speed slider
      const { vMax, wMax } = this.limits();
      const fraction = Math.min(1, Number(this.speed.value) / vMax);
      void this.send(round(this.stick.y * vMax * fraction), round(-this.stick.x * wMax * fraction));
      return;
    }
    const speed = Number(this.speed.value);
    const h = this.held;
    const v = speed * ((h.has("fwd") ? 1 : 0) - (h.has("back") ? 1 : 0));
    const omega = Math.min(3, speed * 8) * ((h.has("left") ? 1 : 0) - (h.has("right") ? 1 : 0));
    void this.send(v, omega);
  }

  private async send(v: number, omega: number): Promise<void> {
    if (this.inFlight) {
      this.pending = [v, omega]; // sent when the one in flight is answered: the final stop is never lost
      return;
    }
    this.inFlight = true;
    try {
      await api("POST", "/api/drive", { v, omega }, 2000);
    } catch (err) {
      this.releaseAll();
      this.ctx.notify(this.ctx.errorText(err));
      if (this.pending && (this.pending[0] !== 0 || this.pending[1] !== 0)) this.pending = null;
    } finally {
      this.inFlight = false;
    }
    const next = this.pending;
    this.pending = null;
    if (next) await this.send(next[0], next[1]);
  }
}
