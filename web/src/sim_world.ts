// The simulated world's boxes (GET /api/sim/world, POST /api/sim/boxes, DELETE /api/sim/boxes/{id},
// DELETE /api/sim/boxes (all); cart2d/simulation/world.py): in simulation only, drawn on the map as
// the physical things they are; the map's "Box" mode drops one where clicked, or picks up the one
// clicked; "Clear boxes" takes them all away. On a real cart the GET answers 404 and the mode, the
// legend entry and the button stay hidden.

import { api, ApiError, type Point, type SimWorldView } from "./api";
import { byId, say } from "./dom";
import type { LiveMap } from "./map";
import type { PanelContext } from "./tuning";

// The box a click drops: 0.2 × 0.2 m, 0.3 m high, in the simulator's default crate colour.
export const DROPPED_BOX = { sx: 0.2, sy: 0.2, height: 0.3, colour: "#b8742f" } as const;

const round3 = (v: number): number => Math.round(v * 1000) / 1000;

export class SimWorld {
  private readonly section: HTMLElement;
  private readonly msg: HTMLOutputElement;
  private version: number | null = null;

  constructor(
    private readonly ctx: PanelContext,
    private readonly map: LiveMap,
  ) {
    this.section = byId("sim-world");
    this.msg = byId<HTMLOutputElement>("sim-world-msg");
    byId("boxes-clear").addEventListener("click", () => void this.clear());
  }

  /** Shows the boxes and the controls in simulation; hides the controls on a real cart (404). */
  async load(): Promise<void> {
    try {
      this.show(await api<SimWorldView>("GET", "/api/sim/world"));
    } catch (err) {
      if (err instanceof ApiError && err.status === 404) {
        this.simulated(false);
        return;
      }
      this.simulated(true); // a simulator that does not answer now: say so where the button is
      say(this.msg, this.ctx.errorText(err), true);
    }
  }

  /** The world as the gateway tells it (/ws "sim_world", or an answer to a change). */
  show(view: SimWorldView): void {
    this.version = view.version;
    this.map.setBoxes(view.boxes);
    this.simulated(true);
    say(this.msg, view.boxes.length === 1 ? "1 box stands in the world." : `${view.boxes.length} boxes stand in the world.`);
  }

  /** A click in Box mode: picks up the box clicked, else drops one there. */
  async click(at: Point): Promise<void> {
    const id = this.map.boxAt(at);
    try {
      if (id !== null) {
        this.show(await api<SimWorldView>("DELETE", `/api/sim/boxes/${encodeURIComponent(id)}`));
        this.ctx.notify(`Box ${id} removed.`, "info");
      } else {
        const box = { x: round3(at[0]), y: round3(at[1]), ...DROPPED_BOX };
        this.show(await api<SimWorldView>("POST", "/api/sim/boxes", { boxes: [box] }));
      }
    } catch (err) {
      this.ctx.notify(this.ctx.errorText(err));
    }
  }

  private async clear(): Promise<void> {
    try {
      this.show(await api<SimWorldView>("DELETE", "/api/sim/boxes"));
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
    }
  }

  private simulated(on: boolean): void {
    this.section.hidden = !on;
    byId("map-mode-box").hidden = !on;
    byId("legend-box").hidden = !on;
    this.section.dataset["loaded"] = "true";
    this.section.dataset["version"] = String(this.version ?? "");
  }
}
