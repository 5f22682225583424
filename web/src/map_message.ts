// What a click on the map answers (a goal refused and why, or the route to it), said on the map
// beside the point clicked: where the user is looking, not in the line under the map, which can be
// below the fold (issue 22: y ≈ 1039 in a 1400 × 1000 window). A click on it, the next answer or a
// few seconds take it away; an error stays longer.

import type { Point } from "./api";

const ERROR_MS = 10_000;
const INFO_MS = 4_000;
const GAP_PX = 14; // between the point clicked and the message
const MARGIN_PX = 4; // from the map's edges

export class MapMessage {
  private timer = 0;

  /** `out`: an element positioned absolutely over the map's canvas (its parent's top left). */
  constructor(private readonly out: HTMLOutputElement) {
    out.hidden = true;
    out.addEventListener("click", () => this.hide());
  }

  /** `text` beside `at` (CSS pixels on the canvas): below it, or above when that leaves no room. */
  say(text: string, at: Point, error = false): void {
    const out = this.out;
    out.textContent = text;
    out.className = error ? "map-msg form-error" : "map-msg";
    out.setAttribute("role", error ? "alert" : "status");
    out.hidden = false;
    const area = out.parentElement?.getBoundingClientRect() ?? { width: 0, height: 0 };
    const w = out.offsetWidth;
    const h = out.offsetHeight;
    const left = Math.min(Math.max(at[0] - w / 2, MARGIN_PX), Math.max(MARGIN_PX, area.width - w - MARGIN_PX));
    const below = at[1] + GAP_PX;
    const top = below + h <= area.height - MARGIN_PX ? below : Math.max(MARGIN_PX, at[1] - GAP_PX - h);
    out.style.left = `${left}px`;
    out.style.top = `${top}px`;
    window.clearTimeout(this.timer);
    this.timer = window.setTimeout(() => this.hide(), error ? ERROR_MS : INFO_MS);
  }

  hide(): void {
    window.clearTimeout(this.timer);
    this.out.hidden = true;
    this.out.textContent = "";
  }
}
