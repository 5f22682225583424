// An on-screen joystick for phones: a round pad with a knob dragged by a finger (or the mouse).
// It reports the knob's offset from the centre as (x, y) in the unit disc — x to the right, y up —
// while held, and null when let go; the panel turns that into (v, ω) and drives.

export type Stick = { x: number; y: number } | null;

const DEAD_ZONE = 0.08; // a finger resting on the centre does not creep

export class Joystick {
  private pointer: number | null = null;

  constructor(
    private readonly pad: HTMLElement,
    private readonly knob: HTMLElement,
    private readonly onChange: (stick: Stick) => void,
  ) {
    pad.addEventListener("pointerdown", (e) => {
      if (this.pointer !== null || e.button !== 0) return;
      e.preventDefault();
      this.pointer = e.pointerId;
      pad.setPointerCapture(e.pointerId);
      pad.classList.add("held");
      this.move(e);
    });
    pad.addEventListener("pointermove", (e) => {
      if (e.pointerId === this.pointer) this.move(e);
    });
    for (const end of ["pointerup", "pointercancel", "lostpointercapture"] as const) {
      pad.addEventListener(end, (e) => {
        if (e.pointerId === this.pointer) this.release();
      });
    }
    pad.addEventListener("contextmenu", (e) => e.preventDefault());
  }

  /** Lets go of the knob (the pointer went up, the window lost focus, an emergency stop). */
  release(): void {
    const id = this.pointer;
    this.pointer = null;
    if (id !== null && this.pad.hasPointerCapture(id)) this.pad.releasePointerCapture(id);
    this.pad.classList.remove("held");
    this.place(0, 0);
    this.onChange(null);
  }

  private move(e: PointerEvent): void {
    const box = this.pad.getBoundingClientRect();
    const radius = (box.width - this.knob.offsetWidth) / 2;
    if (radius <= 0) return;
    let dx = (e.clientX - (box.left + box.width / 2)) / radius;
    let dy = (e.clientY - (box.top + box.height / 2)) / radius;
    const r = Math.hypot(dx, dy);
    if (r > 1) {
      dx /= r;
      dy /= r;
    }
    this.place(dx * radius, dy * radius);
    const x = Math.abs(dx) < DEAD_ZONE ? 0 : dx;
    const y = Math.abs(dy) < DEAD_ZONE ? 0 : -dy;
    this.pad.dataset["x"] = x.toFixed(3);
    this.pad.dataset["y"] = y.toFixed(3);
    this.onChange({ x, y });
  }

  private place(px: number, py: number): void {
    this.knob.style.transform = `translate(calc(-50% + ${px.toFixed(1)}px), calc(-50% + ${py.toFixed(1)}px))`;
    if (px === 0 && py === 0) {
      this.pad.dataset["x"] = "0";
      this.pad.dataset["y"] = "0";
    }
  }
}
