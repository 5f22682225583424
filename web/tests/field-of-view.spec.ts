// The field of view's cut at the walls (src/field_of_view.ts), on its own: a floor plan's
// occupied cells, the near edge behind a wall, polygons not in the gateway's shape. No page: the
// module is plain TypeScript (the map's own drawing of it is in ux-map.spec.ts).

import { expect, test } from "@playwright/test";

import { clipFieldOfView, type FloorCells, floorOccupied } from "../src/field_of_view";

type Point = [number, number];

/** A 40 × 40 floor plan of 5 cm cells from (0, 0), its column of cells at x = 1.0 to 1.05 occupied
 * from y = 0.7 up (the image's top row is the highest y). */
function plan(): FloorCells {
  const width = 40;
  const height = 40;
  const occupied = new Uint8Array(width * height);
  for (let row = 0; row < height; row++) {
    const y = (height - 1 - row) * 0.05; // the cell's lower edge
    if (y >= 0.7 - 1e-9) occupied[row * width + 20] = 1;
  }
  return { origin: [0, 0], resolution: 0.05, width, height, occupied };
}

test("a floor plan's cells are read with the image's top row the highest y", () => {
  const f = plan();
  expect(floorOccupied(f, 1.02, 0.72)).toBe(true);
  expect(floorOccupied(f, 1.02, 1.99)).toBe(true);
  expect(floorOccupied(f, 1.02, 0.68)).toBe(false);
  expect(floorOccupied(f, 0.98, 1.0)).toBe(false);
  expect(floorOccupied(f, 5, 5)).toBe(false); // off the plan: the arena decides
});

test("each scan line ends at the first wall along it; a line that misses the wall keeps its end", () => {
  const f = plan();
  const blocked = (x: number, y: number): boolean => x < 0 || y < 0 || x > 2 || y > 2 || floorOccupied(f, x, y);
  // facing east from (0.2, 1.0): near edge left to right, far edge right to left
  const fov: Point[] = [
    [0.4, 1.1],
    [0.4, 0.9],
    [1.8, 0.3],
    [1.8, 1.7],
  ];
  const seen = clipFieldOfView(fov, [0.2, 1.0], blocked, 0.025);
  // the gateway's two lines and three between them: five near points, five far ones
  expect(seen).toHaveLength(10);
  const far = seen.slice(5).reverse(); // left to right
  const left = far[0] as Point;
  const right = far[4] as Point;
  expect(left[0]).toBeGreaterThan(0.99); // cut at the wall's face, x = 1.0
  expect(left[0]).toBeLessThan(1.0 + 1e-9);
  expect(right).toEqual([1.8, 0.3]); // passes below the wall's end (y = 0.7) at y = 0.64
  for (const p of seen) expect(blocked(p[0], p[1])).toBe(false);
});

test("a wall between the cart and a line's near end: the line sees nothing", () => {
  const blocked = (x: number): boolean => x >= 0.3 && x < 0.35; // a thin wall across
  const fov: Point[] = [
    [0.5, 0.1],
    [0.5, -0.1],
    [1.5, -0.5],
    [1.5, 0.5],
  ];
  const seen = clipFieldOfView(fov, [0, 0], blocked, 0.01);
  for (const [x] of seen) expect(x).toBeLessThan(0.3);
});

test("a polygon not in the gateway's shape is left as it is", () => {
  const triangle: Point[] = [
    [0, 0],
    [1, 0],
    [0, 1],
  ];
  expect(clipFieldOfView(triangle, null, () => true, 0.01)).toEqual(triangle);
});
