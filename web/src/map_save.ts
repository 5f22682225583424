// "Save map" (issue 26): what the camera has seen, written by the gateway as a ROS map_server
// map (POST /api/map/save: maps/NAME.yaml and NAME.pgm in its folder).
import { api } from "./api";
import { byId as $, say } from "./dom";
import type { PanelContext } from "./tuning";

interface Saved {
  yaml: string;
  resolution_m: number;
  counts: { free: number; occupied: number; unknown: number };
}

export function initMapSave(ctx: PanelContext): void {
  const name = $<HTMLInputElement>("map-save-name");
  const msg = $("perceived-msg");
  $("map-save").addEventListener("click", () => {
    void (async () => {
      try {
        const saved = await api<Saved>("POST", "/api/map/save", { name: name.value.trim() });
        const c = saved.counts;
        say(msg, `Saved ${saved.yaml}: ${c.free} free, ${c.occupied} occupied, ${c.unknown} unknown cells.`);
      } catch (err) {
        say(msg, ctx.errorText(err), true);
      }
    })();
  });
}
