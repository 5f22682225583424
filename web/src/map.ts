// The live map on a canvas: the floor plan (walls, unknown space shaded), grid nodes, obstacles as
// the cells they fill (with the footprint they keep the cart's centre out of), the planned path
// and current waypoint, the goal, a raw path sent past the planner, the robot's pose and
// footprint from odometry with its trail, and, in simulation, the true pose and its trail.
// Axes in metres; zoom and pan with the wheel, a drag, a pinch or the buttons; fit-to-map; the
// cursor's x, y; in "pose" mode a drag sets the pose (where the cart is, then the way it faces),
// as RViz's 2D Pose Estimate. In simulation, the world's boxes (physical, not the map: GET
// /api/sim/world) are drawn as what they are, in their colour and outlined; in "box" mode a click
// drops one or picks one up (sim_world.ts).
//
// The canvas publishes its world-to-screen transform as data attributes (data-origin-x,
// data-origin-y: CSS pixels of the world's (0, 0); data-scale: CSS pixels per metre), updated at
// every zoom and pan, so tools and tests can find a node without reverse-engineering the drawing;
// data-arena is the walls it draws ("x_min y_min x_max y_max", metres); data-boxes the number of
// simulated boxes drawn; data-plan the waypoints of the plan drawn (0: none); data-fov-extent the
// field of view drawn, cut at the walls ("x_min y_min x_max y_max", metres).

import type { Arena, MapView, Plan, Point, SimBox } from "./api";
import { cssVar } from "./dom";
import { clipFieldOfView, type FloorCells, floorOccupied } from "./field_of_view";
import { AXIS_BOTTOM_PX, Viewport, drawAxes, sizeCanvas } from "./map_view";
import type { LocalisationMessage } from "./generated/live";
import { drawLocalisation, inMap } from "./localisation";

export interface Pose {
  x: number;
  y: number;
  theta: number;
}

export type MapMode = "obstacle" | "goto" | "pose" | "box";

export interface MapActions {
  click: (world: Point, node: Point | null) => void;
  setPose: (pose: Pose) => void;
}

const TRAIL_MAX = 3000;
const TRAIL_MIN_STEP_M = 0.004;
const PAD_M = 0.3; // room around the nodes when the gateway gives no walls
const WALL_PAD_M = 0.04; // room outside the walls for their line width
const DRAG_PX = 4; // a press that moves less is a click
const WHEEL_ZOOM = 0.0015; // per wheel delta unit (pixels)
const BUTTON_ZOOM = 1.5;
const MAX_NODE_DOTS = 20000;
const MAX_KEEPOUT_DISCS = 2000;

// map_server's trinary grey levels in the floor plan's PNG (cart2d/maps/ros.py)
const PNG_OCCUPIED = 0;
const PNG_UNKNOWN = 205;

interface Press {
  id: number;
  x: number;
  y: number;
}

export class LiveMap {
  map: MapView | null = null;
  plan: Plan | null = null;
  goal: Point | null = null;
  waypointIndex = -1;
  driving = false;
  mode: MapMode = "goto"; // a newcomer's first click sends the cart, it does not add an obstacle
  pose: Pose | null = null;
  truth: Pose | null = null;
  private rawPath: Point[] | null = null;
  private localisation: LocalisationMessage | null = null;
  private hiddenPlan = ""; // a plan not to draw again (from before a reset or a new pose)
  private readonly trail: Point[] = [];
  private readonly truthTrail: Point[] = [];
  private obstacleKeys = new Set<string>();
  private perceived: { resolution: number; cells: [number, number, number][] } = { resolution: 0.05, cells: [] };
  private fov: Point[] = []; // as the gateway sent it
  private fovSeen: Point[] | null = null; // cut at the walls (clipFieldOfView); null: not yet
  private boxes: SimBox[] = [];
  private hits: Point[] = [];
  private readonly view = new Viewport();
  private cssW = 200;
  private cssH = 200;
  private dirty = true;
  private hover: Point | null = null;
  private floor: HTMLCanvasElement | null = null; // the floor plan, recoloured
  private floorUrl = "";
  private floorCells: FloorCells | null = null; // the floor plan's walls, for the field of view
  private readonly presses = new Map<number, Press>();
  private dragged = false;
  private pinch = 0; // the distance between two pointers at the last move
  private poseDrag: { from: Point; to: Point } | null = null;

  constructor(
    private readonly canvas: HTMLCanvasElement,
    private readonly actions: MapActions,
    private readonly cursor: HTMLElement | null = null,
  ) {
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement ?? canvas);
    canvas.style.touchAction = "none"; // the map's own pinch and drag, not the page's
    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", (e) => this.up(e));
    canvas.addEventListener("pointercancel", (e) => this.cancel(e));
    canvas.addEventListener("pointerleave", () => {
      this.hover = null;
      this.showCursor(null);
      this.invalidate();
    });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      this.view.zoomAt(e.offsetX, e.offsetY, Math.exp(-e.deltaY * WHEEL_ZOOM));
      this.viewChanged();
    }, { passive: false });
    const frame = (): void => {
      if (this.dirty) {
        this.dirty = false;
        this.draw();
      }
      requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  }

  // -- what is drawn -------------------------------------------------------------------------------
  setMap(map: MapView): void {
    const newExtent = JSON.stringify(this.map?.arena) !== JSON.stringify(map.arena);
    // A finished route was planned on the map before: not drawn through what changed since (a
    // route being driven stays: the gateway replans it if the change blocks it).
    if (this.map && map.version !== this.map.version && !this.driving) this.hidePlan();
    this.map = map;
    this.fovSeen = null;
    this.obstacleKeys = new Set(map.obstacles.map(([x, y]) => this.key(x, y)));
    this.canvas.dataset["obstacles"] = String(map.obstacles.length);
    this.canvas.dataset["mapVersion"] = String(map.version ?? 0);
    const url = map.floor_plan?.image ?? "";
    if (url !== this.floorUrl) {
      this.floorUrl = url;
      this.floor = null;
      this.floorCells = null;
      if (url) void this.loadFloor(url);
    }
    if (newExtent) this.view.fitted = true;
    this.resize();
  }

  /** What the camera believes occupied: drawn apart from the user's obstacles, opacity = p. */
  setPerceived(resolution: number, cells: [number, number, number][]): void {
    this.perceived = { resolution, cells };
    this.canvas.dataset["perceived"] = String(cells.length);
    this.invalidate();
  }

  /** The pose filter's markers and the pose's uncertainty (localisation.ts). */
  setLocalisation(loc: LocalisationMessage): void {
    this.localisation = loc;
    this.canvas.dataset["markers"] = String(loc.markers.length);
    this.canvas.dataset["localised"] = loc.pose ? "yes" : "no";
    this.invalidate();
  }

  /** The camera's field of view and the obstacle bases of its last processed frame. */
  setCamera(fov: Point[], hits: Point[]): void {
    this.fov = fov;
    this.fovSeen = null;
    this.hits = hits;
    this.canvas.dataset["fov"] = String(fov.length);
    this.invalidate();
  }

  /** The simulated world's boxes (what is physically there), drawn apart from the map. */
  setBoxes(boxes: SimBox[]): void {
    this.boxes = boxes;
    this.canvas.dataset["boxes"] = String(boxes.length);
    this.invalidate();
  }

  /** The id of the simulated box under `p` (the topmost drawn), or null. */
  boxAt(p: Point): string | null {
    for (let k = this.boxes.length - 1; k >= 0; k--) {
      const b = this.boxes[k];
      if (b && Math.abs(p[0] - b.x) <= b.sx / 2 && Math.abs(p[1] - b.y) <= b.sy / 2) return b.id;
    }
    return null;
  }

  hasObstacle(node: Point): boolean {
    return this.obstacleKeys.has(this.key(node[0], node[1]));
  }

  /** The mission's plan; a plan hidden by hidePlan() stays hidden until another one comes. */
  setPlan(plan: Plan | null, goal: Point | null): void {
    const key = plan ? JSON.stringify(plan.waypoints) : "";
    this.plan = key && key === this.hiddenPlan ? null : plan;
    this.goal = this.plan ? goal : null;
    if (this.plan) this.rawPath = null;
    this.canvas.dataset["plan"] = String(this.plan?.waypoints.length ?? 0);
    this.invalidate();
  }

  /** Stops drawing the current plan (the pose it was planned from is gone: a reset, a new pose). */
  hidePlan(): void {
    if (this.plan) this.hiddenPlan = JSON.stringify(this.plan.waypoints);
    this.plan = null;
    this.goal = null;
    this.setRawPath(null);
    this.canvas.dataset["plan"] = "0";
  }

  /** A path sent straight to the firmware (GOTO, WAIT_XY_ARRAY): drawn, and marked as unplanned. */
  setRawPath(points: Point[] | null): void {
    this.rawPath = points && points.length ? points : null;
    this.canvas.dataset["rawPath"] = String(this.rawPath?.length ?? 0);
    this.invalidate();
  }

  /** The firmware's pose (odometry), drawn in `map` (localisation.ts). */
  setPose(odometry: Pose): void {
    const pose = inMap(odometry, this.localisation?.map_to_odom);
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

  // -- the view ------------------------------------------------------------------------------------
  zoom(factor: number): void {
    this.view.zoomAt(this.cssW / 2, (this.cssH - AXIS_BOTTOM_PX) / 2, factor);
    this.viewChanged();
  }

  zoomIn(): void {
    this.zoom(BUTTON_ZOOM);
  }

  zoomOut(): void {
    this.zoom(1 / BUTTON_ZOOM);
  }

  fit(): void {
    this.view.fit(this.extent(), this.cssW, this.cssH);
    this.viewChanged();
  }

  toScreen(x: number, y: number): Point {
    return this.view.toScreen(x, y);
  }

  toWorld(px: number, py: number): Point {
    return this.view.toWorld(px, py);
  }

  /** The node within half a step of `p`, or null (outside the grid). */
  nearestNode(p: Point): Point | null {
    const m = this.map;
    if (!m) return null;
    const [ox, oy] = m.origin_m ?? [0, 0];
    const i = Math.round((p[0] - ox) / m.step_m);
    const j = Math.round((p[1] - oy) / m.step_m);
    if (i < 0 || j < 0 || i >= m.cols || j >= m.rows) return null;
    const nx = ox + i * m.step_m;
    const ny = oy + j * m.step_m;
    if (Math.max(Math.abs(p[0] - nx), Math.abs(p[1] - ny)) > m.step_m * 0.5) return null;
    return [nx, ny];
  }

  private key(x: number, y: number): string {
    const m = this.map;
    const step = m?.step_m ?? 1;
    const [ox, oy] = m?.origin_m ?? [0, 0];
    return `${Math.round((x - ox) / step)},${Math.round((y - oy) / step)}`;
  }

  /** The walls, or (an older gateway) the nodes' bounding box with PAD_M around it. */
  private arena(): Arena {
    const m = this.map;
    if (m?.arena) return m.arena;
    const w = m ? (m.cols - 1) * m.step_m : 2;
    const h = m ? (m.rows - 1) * m.step_m : 2;
    return { x_min: -PAD_M, y_min: -PAD_M, x_max: w + PAD_M, y_max: h + PAD_M };
  }

  /** The world rectangle fitted: the arena and a little room for the walls' line. */
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
    if (!this.canvas.parentElement) return;
    const e = this.extent();
    const { cssW, cssH } = sizeCanvas(this.canvas, e, 0.7);
    this.cssW = cssW;
    this.cssH = cssH;
    if (this.view.fitted) this.view.fit(e, cssW, cssH);
    const a = this.arena();
    this.canvas.dataset["arena"] = [a.x_min, a.y_min, a.x_max, a.y_max].map((v) => v.toFixed(3)).join(" ");
    this.viewChanged();
  }

  private viewChanged(): void {
    this.canvas.dataset["originX"] = this.view.ox.toFixed(2);
    this.canvas.dataset["originY"] = this.view.oy.toFixed(2);
    this.canvas.dataset["scale"] = this.view.scale.toFixed(4);
    this.canvas.dataset["fitted"] = String(this.view.fitted);
    this.invalidate();
  }

  // -- pointers ------------------------------------------------------------------------------------
  private down(e: PointerEvent): void {
    if (e.button !== 0) return;
    this.canvas.setPointerCapture(e.pointerId);
    this.presses.set(e.pointerId, { id: e.pointerId, x: e.offsetX, y: e.offsetY });
    if (this.presses.size === 1) {
      this.dragged = false;
      if (this.mode === "pose") {
        const at = this.toWorld(e.offsetX, e.offsetY);
        this.poseDrag = { from: at, to: at };
      }
    } else {
      this.poseDrag = null; // a second finger: a pinch, not a pose
      this.dragged = true;
      this.pinch = this.spread();
    }
  }

  private move(e: PointerEvent): void {
    const world = this.toWorld(e.offsetX, e.offsetY);
    this.showCursor(world);
    this.hover = this.mode === "obstacle" ? this.nearestNode(world) : null;
    const press = this.presses.get(e.pointerId);
    if (!press) {
      this.invalidate();
      return;
    }
    if (this.presses.size >= 2) {
      press.x = e.offsetX;
      press.y = e.offsetY;
      const spread = this.spread();
      if (this.pinch > 0 && spread > 0) {
        const [cx, cy] = this.centre();
        this.view.zoomAt(cx, cy, spread / this.pinch);
        this.viewChanged();
      }
      this.pinch = spread;
      return;
    }
    const dx = e.offsetX - press.x;
    const dy = e.offsetY - press.y;
    if (!this.dragged && Math.hypot(dx, dy) < DRAG_PX) return;
    this.dragged = true;
    if (this.poseDrag) {
      this.poseDrag.to = world;
      this.invalidate();
      return;
    }
    this.view.pan(dx, dy);
    press.x = e.offsetX;
    press.y = e.offsetY;
    this.viewChanged();
  }

  private up(e: PointerEvent): void {
    const press = this.presses.get(e.pointerId);
    if (!press) return;
    this.presses.delete(e.pointerId);
    if (this.presses.size > 0) return; // the pinch goes on with one finger less
    const world = this.toWorld(e.offsetX, e.offsetY);
    const drag = this.poseDrag;
    this.poseDrag = null;
    if (drag) {
      const [fx, fy] = drag.from;
      const theta = this.dragged
        ? Math.atan2(world[1] - fy, world[0] - fx)
        : (this.pose?.theta ?? 0); // a click: the place, keeping the heading
      this.actions.setPose({ x: fx, y: fy, theta });
      this.invalidate();
      return;
    }
    if (!this.dragged) this.actions.click(world, this.nearestNode(world));
  }

  private cancel(e: PointerEvent): void {
    this.presses.delete(e.pointerId);
    this.poseDrag = null;
    this.invalidate();
  }

  private spread(): number {
    const [a, b] = [...this.presses.values()];
    return a && b ? Math.hypot(a.x - b.x, a.y - b.y) : 0;
  }

  private centre(): Point {
    const [a, b] = [...this.presses.values()];
    return a && b ? [(a.x + b.x) / 2, (a.y + b.y) / 2] : [this.cssW / 2, this.cssH / 2];
  }

  private showCursor(world: Point | null): void {
    if (!this.cursor) return;
    if (!world) {
      this.cursor.textContent = "x –  y –";
      delete this.cursor.dataset["x"];
      delete this.cursor.dataset["y"];
      return;
    }
    const digits = this.view.scale > 500 ? 3 : 2;
    const text = (v: number): string => (Number(v.toFixed(digits)) === 0 ? 0 : v).toFixed(digits); // no "-0.00"
    this.cursor.textContent = `x ${text(world[0])} m  y ${text(world[1])} m`;
    this.cursor.dataset["x"] = world[0].toFixed(4);
    this.cursor.dataset["y"] = world[1].toFixed(4);
  }

  // -- the floor plan ------------------------------------------------------------------------------
  private async loadFloor(url: string): Promise<void> {
    const image = new Image();
    image.src = url;
    try {
      await image.decode();
    } catch {
      return; // drawn without it; the next map message tries again
    }
    if (url !== this.floorUrl) return; // another map came meanwhile
    const css = getComputedStyle(document.documentElement);
    const occupied = rgb(cssVar("--map-obstacle", "#333", css));
    const unknown = rgb(cssVar("--map-unknown", "#94a3b8", css));
    const out = document.createElement("canvas");
    out.width = image.naturalWidth;
    out.height = image.naturalHeight;
    const ctx = out.getContext("2d");
    if (!ctx) return;
    ctx.drawImage(image, 0, 0);
    const pixels = ctx.getImageData(0, 0, out.width, out.height);
    const d = pixels.data;
    const occupiedCells = new Uint8Array(out.width * out.height);
    for (let k = 0; k < d.length; k += 4) {
      const grey = d[k] ?? 255;
      if (grey === PNG_OCCUPIED) occupiedCells[k / 4] = 1;
      const colour = grey === PNG_OCCUPIED ? occupied : grey === PNG_UNKNOWN ? unknown : null;
      if (colour) {
        d[k] = colour[0];
        d[k + 1] = colour[1];
        d[k + 2] = colour[2];
        d[k + 3] = grey === PNG_OCCUPIED ? 255 : 90; // unknown: shaded
      } else {
        d[k + 3] = 0;
      }
    }
    ctx.putImageData(pixels, 0, 0);
    this.floor = out;
    const plan = this.map?.floor_plan;
    this.floorCells = plan
      ? { origin: plan.origin_m, resolution: plan.resolution_m, width: out.width, height: out.height, occupied: occupiedCells }
      : null;
    this.fovSeen = null;
    this.canvas.dataset["floorPlan"] = `${out.width}x${out.height}`;
    this.invalidate();
  }

  // -- drawing -------------------------------------------------------------------------------------
  private draw(): void {
    const ctx = this.canvas.getContext("2d");
    if (!ctx) return;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const cssW = this.cssW;
    const cssH = this.cssH;
    ctx.clearRect(0, 0, cssW, cssH);
    const m = this.map;
    const s = this.view.scale;
    const css = getComputedStyle(document.documentElement); // once per draw: dark mode changes it
    const colors = {
      node: cssVar("--map-node", "#9aa4b2", css),
      obstacle: cssVar("--map-obstacle", "#333", css),
      keepout: cssVar("--map-keepout", "rgba(200,60,60,0.12)", css),
      path: cssVar("--map-path", "#2a9d8f", css),
      raw: cssVar("--map-raw", "#d97706", css),
      robot: cssVar("--map-robot", "#1d4ed8", css),
      truth: cssVar("--map-truth", "#e76f51", css),
      border: cssVar("--map-border", "#cbd5e1", css),
      wall: cssVar("--map-wall", "#475569", css),
      text: cssVar("--muted", "#64748b", css),
      band: cssVar("--map-axis-band", "rgba(127,127,127,0.08)", css),
      perceived: cssVar("--map-perceived", "#9333ea", css),
      fov: cssVar("--map-fov", "#0891b2", css),
    };

    if (m) this.drawMap(ctx, m, s, colors);
    this.fillBoxes(ctx, s);
    this.drawPerception(ctx, s, colors);
    this.outlineBoxes(ctx, s); // over the perceived cells: what stands there, against what was seen
    this.drawPaths(ctx, colors);
    if (this.localisation) drawLocalisation(ctx, this.localisation, (x, y) => this.toScreen(x, y), s, colors.fov);

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
    if (this.poseDrag) {
      const { from, to } = this.poseDrag;
      const theta = Math.atan2(to[1] - from[1], to[0] - from[0]);
      this.robot(ctx, { x: from[0], y: from[1], theta }, radius, colors.path, true);
    }
    drawAxes(ctx, this.view, cssW, cssH, { text: colors.text, grid: colors.text, band: colors.band });
  }

  private drawMap(
    ctx: CanvasRenderingContext2D,
    m: MapView,
    s: number,
    colors: Record<string, string>,
  ): void {
    const plan = m.floor_plan;
    if (plan && this.floor) {
      const [ox, oy] = plan.origin_m;
      const [px, py] = this.toScreen(ox, oy + plan.height * plan.resolution_m);
      ctx.imageSmoothingEnabled = false; // cells stay cells at any zoom
      ctx.drawImage(this.floor, px, py, plan.width * plan.resolution_m * s, plan.height * plan.resolution_m * s);
      ctx.imageSmoothingEnabled = true;
    }
    // the arena's walls: a solid outline, its inner edge on the wall
    const a = this.arena();
    const [wx0, wy0] = this.toScreen(a.x_min, a.y_min);
    const [wx1, wy1] = this.toScreen(a.x_max, a.y_max);
    const wallPx = 3;
    ctx.strokeStyle = colors["wall"] ?? "#475569";
    ctx.lineWidth = wallPx;
    ctx.strokeRect(wx0 - wallPx / 2, wy1 - wallPx / 2, wx1 - wx0 + wallPx, wy0 - wy1 + wallPx);

    const [gx, gy] = m.origin_m ?? [0, 0];
    const [x0, y0] = this.toScreen(gx, gy);
    const [x1, y1] = this.toScreen(gx + (m.cols - 1) * m.step_m, gy + (m.rows - 1) * m.step_m);
    // the area the cart's centre may reach (the nodes' bounding box)
    ctx.strokeStyle = colors["border"] ?? "#cbd5e1";
    ctx.lineWidth = 1;
    ctx.strokeRect(x0, y1, x1 - x0, y0 - y1);

    if (m.obstacles.length <= MAX_KEEPOUT_DISCS) {
      ctx.fillStyle = colors["keepout"] ?? "";
      for (const [ox, oy] of m.obstacles) {
        const [px, py] = this.toScreen(ox, oy);
        ctx.beginPath();
        ctx.arc(px, py, m.footprint_radius_m * s, 0, 2 * Math.PI);
        ctx.fill();
      }
    }
    const spacing = m.step_m * s;
    const v = this.view.visible(this.cssW, this.cssH);
    const i0 = Math.max(0, Math.floor((v.x_min - gx) / m.step_m));
    const i1 = Math.min(m.cols - 1, Math.ceil((v.x_max - gx) / m.step_m));
    const j0 = Math.max(0, Math.floor((v.y_min - gy) / m.step_m));
    const j1 = Math.min(m.rows - 1, Math.ceil((v.y_max - gy) / m.step_m));
    if (spacing >= 14 && (i1 - i0 + 1) * (j1 - j0 + 1) <= MAX_NODE_DOTS) {
      ctx.fillStyle = colors["node"] ?? "";
      const r = Math.min(3, spacing * 0.12);
      for (let i = i0; i <= i1; i++) {
        for (let j = j0; j <= j1; j++) {
          const [px, py] = this.toScreen(gx + i * m.step_m, gy + j * m.step_m);
          ctx.beginPath();
          ctx.arc(px, py, r, 0, 2 * Math.PI);
          ctx.fill();
        }
      }
    }
    // obstacles: the cells they fill, at least 2 px across
    ctx.fillStyle = colors["obstacle"] ?? "";
    const half = Math.max(1, spacing / 2);
    for (const [ox, oy] of m.obstacles) {
      const [px, py] = this.toScreen(ox, oy);
      ctx.fillRect(px - half, py - half, 2 * half, 2 * half);
    }
    if (this.hover) {
      const [px, py] = this.toScreen(this.hover[0], this.hover[1]);
      ctx.strokeStyle = colors["robot"] ?? "";
      ctx.lineWidth = 1.5;
      ctx.strokeRect(px - half - 2, py - half - 2, 2 * half + 4, 2 * half + 4);
    }
  }

  /** The simulator's boxes: their own colour, half see-through, outlined solid and crossed, so they
   * read as physical things rather than the map's obstacle cells or the camera's perceived ones. */
  private fillBoxes(ctx: CanvasRenderingContext2D, s: number): void {
    for (const b of this.boxes) {
      const [px, py, w, h] = this.boxOnScreen(b, s);
      ctx.fillStyle = b.colour;
      ctx.globalAlpha = 0.55;
      ctx.fillRect(px, py, w, h);
      ctx.globalAlpha = 1;
    }
  }

  private outlineBoxes(ctx: CanvasRenderingContext2D, s: number): void {
    for (const b of this.boxes) {
      const [px, py, w, h] = this.boxOnScreen(b, s);
      ctx.strokeStyle = b.colour;
      ctx.lineWidth = 2;
      ctx.strokeRect(px, py, w, h);
      ctx.beginPath(); // a crate's cross: what stands there, not a cell of the map
      ctx.moveTo(px, py);
      ctx.lineTo(px + w, py + h);
      ctx.moveTo(px + w, py);
      ctx.lineTo(px, py + h);
      ctx.lineWidth = 1;
      ctx.stroke();
    }
  }

  /** A box's top-left corner on screen and its size, px (2 at least: a small box stays visible). */
  private boxOnScreen(b: SimBox, s: number): [number, number, number, number] {
    const [px, py] = this.toScreen(b.x - b.sx / 2, b.y + b.sy / 2);
    return [px, py, Math.max(2, b.sx * s), Math.max(2, b.sy * s)];
  }

  private drawPerception(ctx: CanvasRenderingContext2D, s: number, colors: Record<string, string>): void {
    // perceived cells: squares in their own colour (not the obstacles'), as opaque as they are certain
    const half = Math.max(1, (this.perceived.resolution * s) / 2);
    ctx.fillStyle = colors["perceived"] ?? "";
    for (const [x, y, p] of this.perceived.cells) {
      const [px, py] = this.toScreen(x, y);
      ctx.globalAlpha = Math.min(Math.max(p, 0.15), 1);
      ctx.fillRect(px - half, py - half, 2 * half, 2 * half);
    }
    ctx.globalAlpha = 1;
    const fov = this.seenFieldOfView();
    if (fov.length >= 3) {
      ctx.strokeStyle = colors["fov"] ?? "";
      ctx.fillStyle = colors["fov"] ?? "";
      ctx.setLineDash([6, 4]);
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      fov.forEach(([x, y], k) => {
        const [px, py] = this.toScreen(x, y);
        if (k === 0) ctx.moveTo(px, py);
        else ctx.lineTo(px, py);
      });
      ctx.closePath();
      ctx.globalAlpha = 0.08;
      ctx.fill();
      ctx.globalAlpha = 1;
      ctx.stroke();
      ctx.setLineDash([]);
    }
    ctx.fillStyle = colors["perceived"] ?? "";
    for (const [x, y] of this.hits) {
      const [px, py] = this.toScreen(x, y);
      ctx.beginPath();
      ctx.arc(px, py, 2, 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  /** The field of view cut where the map's walls and obstacles hide the floor (computed once per
   * camera message or map change, from the cart's position then). */
  private seenFieldOfView(): Point[] {
    if (this.fovSeen) return this.fovSeen;
    const m = this.map;
    const step = Math.min(m?.step_m ?? 0.05, this.floorCells?.resolution ?? Infinity) / 2;
    const from: Point | null = this.pose ? [this.pose.x, this.pose.y] : null;
    const seen = clipFieldOfView(this.fov, from, (x, y) => this.hidesFloor(x, y), step);
    this.fovSeen = seen;
    const xs = seen.map((p) => p[0]);
    const ys = seen.map((p) => p[1]);
    this.canvas.dataset["fovExtent"] = seen.length
      ? [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)].map((v) => v.toFixed(3)).join(" ")
      : "";
    return seen;
  }

  /** Whether the camera cannot see the floor at (x, y): beyond the walls, in a floor plan's
   * occupied cell, or in a cell of the user's obstacles (as drawn). */
  private hidesFloor(x: number, y: number): boolean {
    const a = this.arena();
    if (x < a.x_min || x > a.x_max || y < a.y_min || y > a.y_max) return true;
    const node = this.obstacleKeys.size ? this.nearestNode([x, y]) : null;
    if (node && this.hasObstacle(node)) return true;
    return this.floorCells !== null && floorOccupied(this.floorCells, x, y);
  }

  private drawPaths(ctx: CanvasRenderingContext2D, colors: Record<string, string>): void {
    // planned path: the grid path thin, the waypoints the firmware follows bold; while driving
    // from the cart on, else from where it was planned (never a stray line back to the cart)
    const plan = this.plan;
    const path = colors["path"] ?? "";
    if (plan) {
      ctx.strokeStyle = path;
      ctx.setLineDash([4, 4]);
      ctx.lineWidth = 1;
      this.polyline(ctx, plan.grid_path);
      ctx.setLineDash([]);
      ctx.lineWidth = 2.5;
      const live = this.driving && this.pose && this.waypointIndex >= 0;
      const ahead = live ? plan.waypoints.slice(this.waypointIndex) : plan.waypoints;
      const from: Point[] = live && this.pose ? [[this.pose.x, this.pose.y]] : plan.start ? [plan.start] : [];
      this.polyline(ctx, [...from, ...ahead]);
      ctx.fillStyle = path;
      plan.waypoints.forEach(([wx, wy], k) => {
        const [px, py] = this.toScreen(wx, wy);
        ctx.beginPath();
        ctx.arc(px, py, k === this.waypointIndex && this.driving ? 6 : 3.5, 0, 2 * Math.PI);
        if (k === this.waypointIndex && this.driving) {
          ctx.lineWidth = 2;
          ctx.stroke();
        } else {
          ctx.fill();
        }
      });
    }
    if (this.goal) {
      const [gx, gy] = this.toScreen(this.goal[0], this.goal[1]);
      ctx.strokeStyle = path;
      ctx.lineWidth = 2.5;
      ctx.beginPath();
      ctx.moveTo(gx - 7, gy - 7);
      ctx.lineTo(gx + 7, gy + 7);
      ctx.moveTo(gx + 7, gy - 7);
      ctx.lineTo(gx - 7, gy + 7);
      ctx.stroke();
    }
    if (this.rawPath) {
      // sent past the planner: dashed, from the cart, in the warning colour
      ctx.strokeStyle = colors["raw"] ?? "";
      ctx.setLineDash([8, 5]);
      ctx.lineWidth = 2;
      const from: Point[] = this.pose ? [[this.pose.x, this.pose.y]] : [];
      this.polyline(ctx, [...from, ...this.rawPath]);
      ctx.setLineDash([]);
    }
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

/** [r, g, b] of a CSS colour (#rgb, #rrggbb or rgb()/rgba()); grey when unreadable. */
function rgb(colour: string): [number, number, number] {
  const hex = colour.match(/^#([0-9a-f]{3}|[0-9a-f]{6})$/i)?.[1];
  if (hex) {
    const full = hex.length === 3 ? [...hex].map((c) => c + c).join("") : hex;
    return [0, 2, 4].map((k) => parseInt(full.slice(k, k + 2), 16)) as [number, number, number];
  }
  const parts = colour.match(/\d+(\.\d+)?/g)?.map(Number);
  return parts && parts.length >= 3 ? [parts[0] ?? 128, parts[1] ?? 128, parts[2] ?? 128] : [128, 128, 128];
}
