// Loading a floor plan into the gateway from the map's card: a ROS map_server .yaml with the
// image it names (both picked together), or a plain image with its cell size (POST /api/map).

import { api, type MapView } from "./api";

export interface UploadBody {
  image: string; // base64
  yaml?: string;
  name: string;
  resolution_m?: number;
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

/** The request for the files picked: an error sentence when they do not make a map. */
export async function uploadBody(files: File[], resolution: string): Promise<UploadBody | string> {
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
  if (!(cell > 0 && cell <= 10)) return "A plain image needs its cell size in metres (0 to 10).";
  body.resolution_m = cell;
  return body;
}

export async function uploadMap(body: UploadBody): Promise<MapView> {
  return api<MapView>("POST", "/api/map", body, UPLOAD_TIMEOUT_MS);
}
