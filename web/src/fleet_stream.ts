// The fleet manager's live stream (its WebSocket /ws, cart2d/fleet/stream.py): each message a
// FleetUpdate with the whole view, at connection and whenever it changes. While the socket is
// down the page polls GET /api/fleet instead (fleet.ts), and the socket is tried again.

import type { FleetUpdate, FleetView } from "./generated/fleet";
import { wsUrl } from "./token";

const RETRY_FIRST_MS = 500;
const RETRY_MAX_MS = 5000;

export class FleetStream {
  /** Whether views arrive by the stream now (then the page does not poll). */
  live = false;
  private retryMs = RETRY_FIRST_MS;

  constructor(
    private readonly onView: (view: FleetView) => void,
    private readonly onLive: (live: boolean) => void,
  ) {}

  connect(): void {
    // on the page's own host (the manager serves both), with no token
    const ws = new WebSocket(wsUrl(null));
    ws.addEventListener("message", (e) => {
      let update: FleetUpdate;
      try {
        update = JSON.parse(String(e.data)) as FleetUpdate;
      } catch (err) {
        console.warn("unreadable fleet message", err);
        return;
      }
      if (update.type !== "fleet") return;
      if (!this.live) this.setLive(true); // live once a view came, not at the handshake
      this.retryMs = RETRY_FIRST_MS;
      this.onView(update.view);
    });
    ws.addEventListener("close", () => {
      this.setLive(false);
      window.setTimeout(() => this.connect(), this.retryMs);
      this.retryMs = Math.min(this.retryMs * 2, RETRY_MAX_MS);
    });
  }

  private setLive(live: boolean): void {
    this.live = live;
    this.onLive(live);
  }
}
