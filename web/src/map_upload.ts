// Loading a floor plan into the gateway from the map's card: a ROS map_server .yaml with the
// image it names (both picked together), or a plain image with its cell size and the place of its
// lower-left corner, its origin (POST /api/map). The answer says when the cart's pose is off the
// new plan's floor (in a wall, off the plan), with what to do.

import { api, type MapView } from "./api";
import { parseNumber } from "./parse";

export interface UploadBody {
  image: string; // base64
  yaml?: string;
  name: string;
  resolution_m?: number;
  origin_m?: [number, number];
}

export interface UploadAnswer extends MapView {
  pose_warning: string | null; // a sentence when the cart stands off the new plan's free floor
}

const UPLOAD_TIMEOUT_MS = 120_000; // a 2000 x 2000 PGM is 5 MB of base64

function base64(file: File): Promise<string> {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(String(reader.result).replace(/^data:[^,]*,/, ""));
    reader.onerror = () => reject(new Error(`${file.name} could not be read`));
    reader.readAsDataURL(file);
  });
}

/** A plain image's origin typed as "x, y" (metres), or an error sentence. */
export function parseOrigin(text: string): [number, number] | string {
  const parts = text.trim().split(/\s*[,;]\s*|\s+/);
  if (parts.length !== 2) return "A plain image's origin is its lower-left corner: x, y in metres, such as -1.5, -2.";
  const x = parseNumber(parts[0] ?? "", "The origin's x");
  if (!x.ok) return x.message;
  const y = parseNumber(parts[1] ?? "", "The origin's y");
  if (!y.ok) return y.message;
  return [x.value, y.value];
}

/** The request for the files picked: an error sentence when they do not make a map. `origin`:
 * where a plain image's lower-left corner goes, "x, y" in metres (a map_server map has its own). */
export async function uploadBody(files: File[], resolution: string, origin = "0, 0"): Promise<UploadBody | string> {
  const yamls = files.filter((f) => /\.ya?ml$/i.test(f.name));
  const images = files.filter((f) => !/\.ya?ml$/i.test(f.name));
  if (yamls.length > 1 || images.length !== 1) {
    return "Pick one image (.pgm or .png), with its map_server .yaml if it has one.";
  }
  const [image] = images;
  const [yaml] = yamls;
  if (!image) return "Pick an image.";
  const body: UploadBody = { image: await base64(image), name: (yaml ?? image).name };
  if (yaml) {
    body.yaml = await yaml.text();
    return body;
  }
  const cell = Number(resolution);
  if (!(cell >= 0.001 && cell <= 10)) return "A plain image needs its cell size in metres (0.001 to 10).";
  body.resolution_m = cell;
  const corner = parseOrigin(origin);
  if (typeof corner === "string") return corner;
  body.origin_m = corner;
  return body;
}

export async function uploadMap(body: UploadBody): Promise<UploadAnswer> {
  return api<UploadAnswer>("POST", "/api/map", body, UPLOAD_TIMEOUT_MS);
}
