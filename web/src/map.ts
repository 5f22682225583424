// The live map on a canvas: grid nodes, obstacles (with the footprint they keep the cart's centre
// out of), the planned path and current waypoint, the goal, the robot's pose and footprint from
// odometry with its trail, and, in simulation, the true pose and its trail beside it.
//
// The canvas publishes its world-to-screen transform as data attributes (data-origin-x,
// data-origin-y: CSS pixels of the world's (0, 0); data-scale: CSS pixels per metre), so tools
// and tests can find a node without reverse-engineering the drawing; data-arena is the walls it
// draws ("x_min y_min x_max y_max", metres), all inside the drawn extent.

import type { Arena, MapView, Plan, Point } from "./api";
import { cssVar } from "./dom";

export interface Pose {
  x: number;
  y: number;
  theta: number;
}

const TRAIL_MAX = 3000;
const TRAIL_MIN_STEP_M = 0.004;
const PAD_M = 0.3; // room around the nodes when the gateway gives no walls
const WALL_PAD_M = 0.04; // room outside the walls for their line width

export class LiveMap {
  map: MapView | null = null;
  plan: Plan | null = null;
  goal: Point | null = null;
  waypointIndex = -1;
  pose: Pose | null = null;
  truth: Pose | null = null;
  private readonly trail: Point[] = [];
  private readonly truthTrail: Point[] = [];
  private obstacleKeys = new Set<string>();
  private scale = 1;
  private ox = 0;
  private oy = 0;
  private dirty = true;
  private hover: Point | null = null;

  constructor(
    private readonly canvas: HTMLCanvasElement,
    private readonly onClick: (world: Point, node: Point | null) => void,
  ) {
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement ?? canvas);
    canvas.addEventListener("click", (e) => {
      const world = this.toWorld(e.offsetX, e.offsetY);
      this.onClick(world, this.nearestNode(world));
    });
    canvas.addEventListener("pointermove", (e) => {
      this.hover = this.nearestNode(this.toWorld(e.offsetX, e.offsetY));
      this.invalidate();
    });
    canvas.addEventListener("pointerleave", () => {
      this.hover = null;
      this.invalidate();
    });
    const frame = (): void => {
      if (this.dirty) {
        this.dirty = false;
        this.draw();
      }
      requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  }

  setMap(map: MapView): void {
    this.map = map;
    this.obstacleKeys = new Set(map.obstacles.map(([x, y]) => this.key(x, y)));
    this.canvas.dataset["obstacles"] = String(map.obstacles.length);
    this.resize();
  }

  hasObstacle(node: Point): boolean {
    return this.obstacleKeys.has(this.key(node[0], node[1]));
  }

  setPose(pose: Pose): void {
    this.pose = pose;
    push(this.trail, pose);
    this.invalidate();
  }

  setTruth(pose: Pose): void {
    this.truth = pose;
    push(this.truthTrail, pose);
    this.invalidate();
  }

  clearTrails(): void {
    this.trail.length = 0;
    this.truthTrail.length = 0;
    this.invalidate();
  }

  invalidate(): void {
    this.dirty = true;
  }

  private key(x: number, y: number): string {
    const step = this.map?.step_m ?? 1;
    return `${Math.round(x / step)},${Math.round(y / step)}`;
  }

  /** The walls, or (an older gateway) the nodes' bounding box with PAD_M around it. */
  private arena(): Arena {
    const m = this.map;
    if (m?.arena) return m.arena;
    const w = m ? (m.cols - 1) * m.step_m : 2;
    const h = m ? (m.rows - 1) * m.step_m : 2;
    return { x_min: -PAD_M, y_min: -PAD_M, x_max: w + PAD_M, y_max: h + PAD_M };
  }

  /** The world rectangle drawn: the arena and a little room for the walls' line. */
  private extent(): Arena {
    const a = this.arena();
    return {
      x_min: a.x_min - WALL_PAD_M,
      y_min: a.y_min - WALL_PAD_M,
      x_max: a.x_max + WALL_PAD_M,
      y_max: a.y_max + WALL_PAD_M,
    };
  }

  private resize(): void {
    const parent = this.canvas.parentElement;
    if (!parent) return;
    const e = this.extent();
    const w = e.x_max - e.x_min;
    const h = e.y_max - e.y_min;
    const cssW = Math.max(200, parent.clientWidth);
    const cssH = Math.min(cssW * (h / w), Math.max(260, window.innerHeight * 0.7));
    const dpr = window.devicePixelRatio || 1;
    this.canvas.style.width = `${cssW}px`;
    this.canvas.style.height = `${cssH}px`;
    this.canvas.width = Math.round(cssW * dpr);
    this.canvas.height = Math.round(cssH * dpr);
    this.scale = Math.min(cssW / w, cssH / h);
    // centre the world in the canvas; y grows upwards
    this.ox = (cssW - w * this.scale) / 2 - e.x_min * this.scale;
    this.oy = cssH - (cssH - h * this.scale) / 2 + e.y_min * this.scale;
    const a = this.arena();
    this.canvas.dataset["arena"] = [a.x_min, a.y_min, a.x_max, a.y_max].map((v) => v.toFixed(3)).join(" ");
    this.canvas.dataset["originX"] = this.ox.toFixed(2);
    this.canvas.dataset["originY"] = this.oy.toFixed(2);
    this.canvas.dataset["scale"] = this.scale.toFixed(4);
    this.invalidate();
  }

  toScreen(x: number, y: number): Point {
    return [this.ox + x * this.scale, this.oy - y * this.scale];
  }

  toWorld(px: number, py: number): Point {
    return [(px - this.ox) / this.scale, (this.oy - py) / this.scale];
  }

  /** The node within half a step of `p`, or null (outside the grid). */
  nearestNode(p: Point): Point | null {
    const m = this.map;
    if (!m) return null;
    const i = Math.round(p[0] / m.step_m);
    const j = Math.round(p[1] / m.step_m);
    if (i < 0 || j < 0 || i >= m.cols || j >= m.rows) return null;
    const nx = i * m.step_m;
    const ny = j * m.step_m;
    if (Math.hypot(p[0] - nx, p[1] - ny) > m.step_m * 0.5) return null;
    return [nx, ny];
  }

  private draw(): void {
    const ctx = this.canvas.getContext("2d");
    if (!ctx) return;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const cssW = this.canvas.width / dpr;
    const cssH = this.canvas.height / dpr;
    ctx.clearRect(0, 0, cssW, cssH);
    const m = this.map;
    const s = this.scale;
    const css = getComputedStyle(document.documentElement); // once per draw: dark mode changes it
    const colors = {
      node: cssVar("--map-node", "#9aa4b2", css),
      obstacle: cssVar("--map-obstacle", "#333", css),
      keepout: cssVar("--map-keepout", "rgba(200,60,60,0.12)", css),
      path: cssVar("--map-path", "#2a9d8f", css),
      robot: cssVar("--map-robot", "#1d4ed8", css),
      truth: cssVar("--map-truth", "#e76f51", css),
      border: cssVar("--map-border", "#cbd5e1", css),
      wall: cssVar("--map-wall", "#475569", css),
    };

    if (m) {
      // the arena's walls: a solid outline, its inner edge on the wall
      const a = this.arena();
      const [wx0, wy0] = this.toScreen(a.x_min, a.y_min);
      const [wx1, wy1] = this.toScreen(a.x_max, a.y_max);
      const wallPx = 3;
      ctx.strokeStyle = colors.wall;
      ctx.lineWidth = wallPx;
      ctx.strokeRect(wx0 - wallPx / 2, wy1 - wallPx / 2, wx1 - wx0 + wallPx, wy0 - wy1 + wallPx);

      const [x0, y0] = this.toScreen(0, 0);
      const [x1, y1] = this.toScreen((m.cols - 1) * m.step_m, (m.rows - 1) * m.step_m);
      // the area the cart's centre may reach (the nodes' bounding box)
      ctx.strokeStyle = colors.border;
      ctx.lineWidth = 1;
      ctx.strokeRect(x0, y1, x1 - x0, y0 - y1);

      // keep-out discs, then obstacles
      ctx.fillStyle = colors.keepout;
      for (const [ox, oy] of m.obstacles) {
        const [px, py] = this.toScreen(ox, oy);
        ctx.beginPath();
        ctx.arc(px, py, m.footprint_radius_m * s, 0, 2 * Math.PI);
        ctx.fill();
      }
      const spacing = m.step_m * s;
      if (spacing >= 5) {
        ctx.fillStyle = colors.node;
        const r = Math.min(3, spacing * 0.12);
        for (let i = 0; i < m.cols; i++) {
          for (let j = 0; j < m.rows; j++) {
            const [px, py] = this.toScreen(i * m.step_m, j * m.step_m);
            ctx.beginPath();
            ctx.arc(px, py, r, 0, 2 * Math.PI);
            ctx.fill();
          }
        }
      }
      ctx.fillStyle = colors.obstacle;
      const half = Math.max(2, spacing * 0.3);
      for (const [ox, oy] of m.obstacles) {
        const [px, py] = this.toScreen(ox, oy);
        ctx.fillRect(px - half, py - half, 2 * half, 2 * half);
      }
      if (this.hover) {
        const [px, py] = this.toScreen(this.hover[0], this.hover[1]);
        ctx.strokeStyle = colors.robot;
        ctx.lineWidth = 1.5;
        ctx.strokeRect(px - half - 2, py - half - 2, 2 * half + 4, 2 * half + 4);
      }
    }

    // planned path: the grid path thin, the waypoints the firmware follows bold
    if (this.plan) {
      ctx.strokeStyle = colors.path;
      ctx.setLineDash([4, 4]);
      ctx.lineWidth = 1;
      this.polyline(ctx, this.plan.grid_path);
      ctx.setLineDash([]);
      ctx.lineWidth = 2.5;
      const start: Point[] = this.pose && this.waypointIndex <= 0 ? [[this.pose.x, this.pose.y]] : [];
      this.polyline(ctx, [...start, ...this.plan.waypoints]);
      ctx.fillStyle = colors.path;
      this.plan.waypoints.forEach(([wx, wy], k) => {
        const [px, py] = this.toScreen(wx, wy);
        ctx.beginPath();
        ctx.arc(px, py, k === this.waypointIndex ? 6 : 3.5, 0, 2 * Math.PI);
        if (k === this.waypointIndex) {
          ctx.lineWidth = 2;
          ctx.stroke();
        } else {
          ctx.fill();
        }
      });
    }
    if (this.goal) {
      const [gx, gy] = this.toScreen(this.goal[0], this.goal[1]);
      ctx.strokeStyle = colors.path;
      ctx.lineWidth = 2.5;
      ctx.beginPath();
      ctx.moveTo(gx - 7, gy - 7);
      ctx.lineTo(gx + 7, gy + 7);
      ctx.moveTo(gx + 7, gy - 7);
      ctx.lineTo(gx - 7, gy + 7);
      ctx.stroke();
    }

    const radius = (m?.footprint_radius_m ?? 0.17) * s;
    ctx.lineWidth = 1.5;
    ctx.strokeStyle = colors.truth;
    ctx.globalAlpha = 0.7;
    this.polyline(ctx, this.truthTrail);
    ctx.strokeStyle = colors.robot;
    this.polyline(ctx, this.trail);
    ctx.globalAlpha = 1;
    if (this.truth) this.robot(ctx, this.truth, radius, colors.truth, true);
    if (this.pose) this.robot(ctx, this.pose, radius, colors.robot, false);
  }

  private polyline(ctx: CanvasRenderingContext2D, points: readonly Point[]): void {
    if (points.length < 2) return;
    ctx.beginPath();
    points.forEach(([x, y], k) => {
      const [px, py] = this.toScreen(x, y);
      if (k === 0) ctx.moveTo(px, py);
      else ctx.lineTo(px, py);
    });
    ctx.stroke();
  }

  private robot(ctx: CanvasRenderingContext2D, p: Pose, r: number, color: string, outline: boolean): void {
    const [px, py] = this.toScreen(p.x, p.y);
    ctx.beginPath();
    ctx.arc(px, py, r, 0, 2 * Math.PI);
    if (outline) {
      ctx.setLineDash([5, 4]);
      ctx.strokeStyle = color;
      ctx.lineWidth = 2;
      ctx.stroke();
      ctx.setLineDash([]);
    } else {
      ctx.fillStyle = color;
      ctx.globalAlpha = 0.18;
      ctx.fill();
      ctx.globalAlpha = 1;
      ctx.strokeStyle = color;
      ctx.lineWidth = 2;
      ctx.stroke();
    }
    // heading
    ctx.beginPath();
    ctx.moveTo(px, py);
    ctx.lineTo(px + Math.cos(p.theta) * r, py - Math.sin(p.theta) * r);
    ctx.strokeStyle = color;
    ctx.lineWidth = 3;
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(px, py, 3, 0, 2 * Math.PI);
    ctx.fillStyle = color;
    ctx.fill();
  }
}

function push(trail: Point[], p: Pose): void {
  const last = trail[trail.length - 1];
  if (last && Math.hypot(last[0] - p.x, last[1] - p.y) < TRAIL_MIN_STEP_M) return;
  trail.push([p.x, p.y]);
  if (trail.length > TRAIL_MAX) trail.splice(0, trail.length - TRAIL_MAX);
}
