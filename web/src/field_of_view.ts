// The camera's field of view as the map shows it: the floor the camera looks at, cut where the
// map's walls and obstacles hide the floor behind them. The gateway's polygon (/ws "camera",
// cart2d/perception/detection.py field_of_view) is the nearest floor each scan line of the picture
// sees, left to right, then where each line ends (its range or the picture's edge), right to left;
// a scan line is a straight line on the floor away from the camera, so it is cut at the first wall
// along it, from the cart through its near end to its far end. Lines are added between the given
// ones so that a wall's corner between two of them is not cut across.

import type { Point } from "./api";

/** Whether the floor at (x, y), metres, is behind a wall: a wall, an obstacle, outside the map. */
export type Blocked = (x: number, y: number) => boolean;

const LINES_BETWEEN = 4; // lines added between two of the gateway's
const MAX_STEPS = 600; // samples along one line at most
const BISECTIONS = 8; // where a wall begins between a free sample and a blocked one

const lerp = (a: Point, b: Point, t: number): Point => [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];

/** The polygon with each scan line cut at the first blocked point along `from` → near → far
 * (`from`: the cart's position; null: from the near end), sampled every `stepM` metres at most. A
 * polygon not in the gateway's shape (an odd number of points, fewer than four) is returned as is. */
export function clipFieldOfView(fov: readonly Point[], from: Point | null, blocked: Blocked, stepM: number): Point[] {
  const k = fov.length / 2;
  if (fov.length < 4 || !Number.isInteger(k)) return [...fov];
  const lines: [Point, Point][] = [];
  for (let i = 0; i < k; i++) {
    const near = fov[i] as Point;
    const far = fov[fov.length - 1 - i] as Point;
    if (i > 0) {
      const [nearBefore, farBefore] = lines[lines.length - 1] as [Point, Point];
      for (let s = 1; s < LINES_BETWEEN; s++) {
        const t = s / LINES_BETWEEN;
        lines.push([lerp(nearBefore, near, t), lerp(farBefore, far, t)]);
      }
    }
    lines.push([near, far]);
  }
  const start = from && !blocked(from[0], from[1]) ? from : null;
  const cut = lines.map(([near, far]) => {
    const toNear = start ? firstBlocked(start, near, blocked, stepM) : null;
    if (toNear) return [toNear, toNear] as [Point, Point]; // a wall before the near end: nothing seen
    const nearFree = blocked(near[0], near[1]) ? null : near;
    if (!nearFree) return [near, near] as [Point, Point];
    return [near, firstBlocked(near, far, blocked, stepM) ?? far] as [Point, Point];
  });
  return [...cut.map(([near]) => near), ...cut.map(([, far]) => far).reverse()];
}

/** The last free point before the first blocked one on the segment a → b (a is free), or null. */
function firstBlocked(a: Point, b: Point, blocked: Blocked, stepM: number): Point | null {
  const length = Math.hypot(b[0] - a[0], b[1] - a[1]);
  const steps = Math.min(MAX_STEPS, Math.max(1, Math.ceil(length / Math.max(stepM, 1e-4))));
  let free = 0;
  for (let s = 1; s <= steps; s++) {
    const t = s / steps;
    const p = lerp(a, b, t);
    if (!blocked(p[0], p[1])) {
      free = t;
      continue;
    }
    let hit = t;
    for (let n = 0; n < BISECTIONS; n++) {
      const mid = (free + hit) / 2;
      const q = lerp(a, b, mid);
      if (blocked(q[0], q[1])) hit = mid;
      else free = mid;
    }
    return lerp(a, b, free);
  }
  return null;
}

/** A floor plan's occupied cells (map_server's image: the top row is the highest y). */
export interface FloorCells {
  origin: Point; // the lower-left corner of cell (0, 0), m
  resolution: number; // m
  width: number;
  height: number;
  occupied: Uint8Array; // row-major from the image's top row, 1 where occupied
}

export function floorOccupied(f: FloorCells, x: number, y: number): boolean {
  const col = Math.floor((x - f.origin[0]) / f.resolution);
  const row = f.height - 1 - Math.floor((y - f.origin[1]) / f.resolution);
  if (col < 0 || row < 0 || col >= f.width || row >= f.height) return false; // the arena says
  return f.occupied[row * f.width + col] === 1;
}
