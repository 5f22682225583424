// The fleet page's map: the lattice, every cart (pose, heading, the nodes it holds, the rest of
// its route) and the goals not reached yet, fitted to the lattice. A click is a goal (world
// metres). Like the panel's map, the canvas publishes its transform (data-origin-x, data-origin-y,
// data-scale) so a test can click a world point.

import type { Arena, Point } from "./api";
import { cssVar } from "./dom";
import type { CartView, FleetView } from "./generated/fleet";
import { Viewport, sizeCanvas } from "./map_view";

const CART_RADIUS_M = 0.17; // config/robot.toml's footprint, as drawn by the panel's map
const PALETTE = ["#1d4ed8", "#dc2626", "#15803d", "#9333ea", "#ea580c", "#0891b2", "#a16207", "#db2777"];

/** A cart's colour: by its place among the names, so it keeps it from one refresh to the next. */
export function colourOf(name: string, names: string[]): string {
  const k = [...names].sort().indexOf(name);
  return PALETTE[Math.max(k, 0) % PALETTE.length] ?? "#1d4ed8";
}

/** The lattice's extent with one spacing of margin (the walls round its outer nodes). */
function extentOf(view: FleetView): Arena | null {
  const nodes = view.lattice.nodes;
  if (nodes.length === 0) return null;
  const s = view.lattice.spacing_m;
  const xs = nodes.map((n) => n[0]);
  const ys = nodes.map((n) => n[1]);
  return { x_min: Math.min(...xs) - s, y_min: Math.min(...ys) - s, x_max: Math.max(...xs) + s, y_max: Math.max(...ys) + s };
}

export class FleetMap {
  private readonly view = new Viewport();
  private readonly ctx: CanvasRenderingContext2D;
  private fleet: FleetView | null = null;
  private extent: Arena | null = null;
  private cssW = 0;
  private cssH = 0;

  constructor(
    private readonly canvas: HTMLCanvasElement,
    onGoal: (p: Point) => void,
  ) {
    const ctx = canvas.getContext("2d");
    if (!ctx) throw new Error("this browser draws no 2D canvas");
    this.ctx = ctx;
    canvas.addEventListener("click", (e) => {
      if (this.extent) onGoal(this.view.toWorld(e.offsetX, e.offsetY));
    });
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement ?? canvas);
  }

  show(fleet: FleetView): void {
    this.fleet = fleet;
    const extent = extentOf(fleet);
    const changed = JSON.stringify(extent) !== JSON.stringify(this.extent);
    this.extent = extent;
    if (changed) this.resize();
    else this.draw();
  }

  private resize(): void {
    if (!this.canvas.parentElement || !this.extent) return;
    const e = this.extent;
    const { cssW, cssH } = sizeCanvas(this.canvas, e, 0.75);
    this.cssW = cssW;
    this.cssH = cssH;
    this.view.fit(e, cssW, cssH);
    this.canvas.dataset["originX"] = this.view.ox.toFixed(2);
    this.canvas.dataset["originY"] = this.view.oy.toFixed(2);
    this.canvas.dataset["scale"] = this.view.scale.toFixed(4);
    this.draw();
  }

  private draw(): void {
    const fleet = this.fleet;
    if (!fleet || !this.extent) return;
    const ctx = this.ctx;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, this.cssW, this.cssH);
    const style = getComputedStyle(document.documentElement);
    const s = fleet.lattice.spacing_m * this.view.scale;
    ctx.fillStyle = cssVar("--map-node", "#9aa4b2", style);
    for (const [x, y] of fleet.lattice.nodes) {
      const [px, py] = this.view.toScreen(x, y);
      ctx.fillRect(px - 2, py - 2, 4, 4);
    }
    const names = fleet.carts.map((c) => c.name);
    for (const cart of fleet.carts) this.drawHeld(cart, colourOf(cart.name, names), s);
    for (const cart of fleet.carts) this.drawRoute(cart, colourOf(cart.name, names));
    this.drawGoals(fleet, cssVar("--fg", "#1b2430", style));
    for (const cart of fleet.carts) {
      const colour = cart.state === "offline" ? cssVar("--fg-muted", "#5b6675", style) : colourOf(cart.name, names);
      this.drawCart(cart, colour, cssVar("--fg", "#1b2430", style));
    }
    this.canvas.dataset["carts"] = String(fleet.carts.filter((c) => c.position).length);
  }

  private drawHeld(cart: CartView, colour: string, side: number): void {
    this.ctx.fillStyle = `${colour}33`;
    for (const [x, y] of cart.held) {
      const [px, py] = this.view.toScreen(x, y);
      this.ctx.fillRect(px - side * 0.4, py - side * 0.4, side * 0.8, side * 0.8);
    }
  }

  private drawRoute(cart: CartView, colour: string): void {
    if (cart.route.length < 2) return;
    const ctx = this.ctx;
    ctx.strokeStyle = colour;
    ctx.lineWidth = 2;
    ctx.setLineDash([5, 4]);
    ctx.beginPath();
    cart.route.forEach(([x, y], i) => {
      const [px, py] = this.view.toScreen(x, y);
      if (i === 0) ctx.moveTo(px, py);
      else ctx.lineTo(px, py);
    });
    ctx.stroke();
    ctx.setLineDash([]);
  }

  private drawGoals(fleet: FleetView, ink: string): void {
    const ctx = this.ctx;
    ctx.strokeStyle = ink;
    ctx.lineWidth = 2;
    for (const goal of fleet.goals) {
      if (goal.status !== "waiting" && goal.status !== "driving") continue;
      const [px, py] = this.view.toScreen(...goal.at);
      ctx.beginPath();
      ctx.moveTo(px - 6, py - 6);
      ctx.lineTo(px + 6, py + 6);
      ctx.moveTo(px + 6, py - 6);
      ctx.lineTo(px - 6, py + 6);
      ctx.stroke();
    }
  }

  private drawCart(cart: CartView, colour: string, ink: string): void {
    if (!cart.position) return;
    const ctx = this.ctx;
    const [x, y, theta] = cart.position;
    const [px, py] = this.view.toScreen(x, y);
    const r = CART_RADIUS_M * this.view.scale;
    ctx.fillStyle = colour;
    ctx.beginPath();
    ctx.arc(px, py, r, 0, 2 * Math.PI);
    ctx.fill();
    ctx.strokeStyle = "#fff";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(px, py);
    ctx.lineTo(px + r * Math.cos(theta), py - r * Math.sin(theta));
    ctx.stroke();
    ctx.fillStyle = ink;
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(cart.name, px + r + 2, py - r);
  }
}
