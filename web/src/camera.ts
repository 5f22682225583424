// The camera card: the gateway's re-stream of the cart's camera (with what perception drew on
// it), the stream's state, and the button that forgets the perceived cells. Without a camera the
// card says how to give the gateway one instead of showing a broken image. A camera whose frames
// are not taken in (none coming, refused, failing perception) is "blind", in red, with why: the
// gateway stops a mission it goes blind in, and the mission's toast says so.

import { api, type PerceivedMessage } from "./api";
import { byId as $, say } from "./dom";
import type { LiveMap } from "./map";
import type { PanelContext } from "./tuning";

const POLL_MS = 2000;

interface CameraState {
  camera: boolean;
  message?: string;
  connected?: boolean;
  fps?: number;
  age_s?: number | null; // the last frame taken in (decoded, through perception)
  state?: "seeing" | "blind";
  problem?: string; // why blind, in words
  reconnects?: number;
  stream_url?: string;
  url?: string | null;
}

/** What the camera form sends: a base URL (the stock sketch's, stream on port + 1) or, with a
 * path, the stream's own URL; empty: no camera. */
export function cameraSettings(text: string): { url: string | null; stream_url: string | null } {
  const t = text.trim();
  if (!t) return { url: null, stream_url: null };
  let path = "/";
  try {
    const u = new URL(t);
    path = u.pathname + u.search;
  } catch {
    /* the gateway says what is wrong with it */
  }
  return path === "/" || path === "" ? { url: t, stream_url: null } : { url: null, stream_url: t };
}

export class CameraCard {
  private readonly img = $<HTMLImageElement>("camera-view");
  private readonly none = $("camera-none");
  private readonly state = $("camera-state");
  private readonly msg = $("perceived-msg");
  private streaming = false;
  private connected = false; // at the last look: a stream that ended while the camera was away reopens
  private filled = false; // the form shows the gateway's camera once, then what the user types

  constructor(
    private readonly ctx: PanelContext,
    private readonly map: LiveMap,
  ) {
    $("clear-perceived").addEventListener("click", () => void this.clear());
    const form = $<HTMLFormElement>("camera-form");
    form.addEventListener("submit", (e) => {
      e.preventDefault();
      void this.use(String(new FormData(form).get("url") ?? ""));
    });
    void this.poll();
    void this.loadPerceived();
  }

  private async poll(): Promise<void> {
    try {
      this.show(await api<CameraState>("GET", "/api/camera"));
    } catch {
      /* the gateway is away: the link state says so */
    }
    window.setTimeout(() => void this.poll(), POLL_MS);
  }

  private show(s: CameraState): void {
    document.body.dataset["camera"] = s.camera ? "yes" : "no";
    if (!this.filled) {
      $<HTMLInputElement>("camera-url").value = s.camera ? (s.url ?? s.stream_url ?? "") : "";
      this.filled = true;
    }
    this.img.hidden = !s.camera;
    this.none.hidden = s.camera;
    if (!s.camera) {
      this.none.textContent = s.message ?? "No camera.";
      this.state.textContent = "–";
      this.state.classList.remove("form-error");
      delete document.body.dataset["cameraSees"];
      if (this.streaming) this.img.removeAttribute("src");
      this.streaming = false;
      return;
    }
    const back = s.connected === true && !this.connected;
    this.connected = s.connected === true;
    if (!this.streaming || back) {
      // the browser decodes multipart/x-mixed-replace itself; the gateway ends a stream that has
      // had no frame for a few seconds, so it is opened again when the camera is back
      this.img.src = `/api/camera/stream?since=${Date.now()}`;
      this.streaming = true;
    }
    const age = s.age_s === null || s.age_s === undefined ? "no frame taken in yet" : `last frame ${s.age_s.toFixed(1)} s ago`;
    const stream = s.connected ? `${(s.fps ?? 0).toFixed(1)} fps` : `not connected (${s.reconnects ?? 0} reconnects)`;
    const blind = s.state === "blind";
    this.state.textContent = blind ? `blind: ${s.problem || "no frame taken in"}; ${stream}, ${age}` : `${stream}, ${age}`;
    this.state.classList.toggle("form-error", blind);
    document.body.dataset["cameraSees"] = blind ? "no" : "yes";
  }

  private async use(text: string): Promise<void> {
    const out = $("camera-msg");
    try {
      const s = await api<CameraState>("PUT", "/api/settings/camera", cameraSettings(text));
      this.img.removeAttribute("src"); // the stream of the camera before
      this.streaming = false;
      this.show(s);
      say(out, s.camera ? "Saved: the gateway reads this camera now." : "Saved: no camera.");
    } catch (err) {
      say(out, this.ctx.errorText(err), true);
    }
  }

  private async loadPerceived(): Promise<void> {
    try {
      const p = await api<PerceivedMessage>("GET", "/api/perception");
      this.map.setPerceived(p.resolution, p.cells);
    } catch {
      /* shown once /ws says so */
    }
  }

  private async clear(): Promise<void> {
    try {
      const p = await api<PerceivedMessage>("POST", "/api/perception/clear");
      this.map.setPerceived(p.resolution, p.cells);
      say(this.msg, "Perceived cells cleared.");
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
    }
  }
}
