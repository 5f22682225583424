#include "look.hpp"

#include <cmath>
#include <initializer_list>

#include "box.hpp"  // parse_colour

namespace cart2d {

namespace {

// Every member of `v` is one of `keys`; "" or a sentence naming the first that is not.
std::string known_keys(const json::Value& v, const char* where, std::initializer_list<const char*> keys) {
  for (const auto& [key, value] : v.object) {
    bool known = false;
    for (const char* k : keys) known = known || key == k;
    if (!known) {
      std::string list;
      for (const char* k : keys) list += (list.empty() ? "" : ", ") + std::string(k);
      return std::string("unknown key ") + json::quote(key) + " in " + where + " (it has: " + list + ")";
    }
  }
  return "";
}

std::string number(const json::Value& v, const char* where, const char* key, double lo, double hi, double* out) {
  const json::Value* m = v.find(key);
  if (!m) return "";
  if (!m->is_number() || !std::isfinite(m->number) || m->number < lo || m->number > hi)
    return std::string(where) + "." + key + " must be a number in [" + json::number(lo) + ", " + json::number(hi) + "]";
  *out = m->number;
  return "";
}

std::string colour(const json::Value& v, const char* where, const char* key, uint32_t* out) {
  const json::Value* m = v.find(key);
  if (!m) return "";
  if (!m->is_string() || !parse_colour(m->string, out)) return std::string(where) + "." + key + " must be \"#rrggbb\"";
  return "";
}

std::string flag(const json::Value& v, const char* where, const char* key, bool* out) {
  const json::Value* m = v.find(key);
  if (!m) return "";
  if (!m->is_bool()) return std::string(where) + "." + key + " must be true or false";
  *out = m->boolean;
  return "";
}

// The first non-empty sentence of a list of checks.
std::string first(std::initializer_list<std::string> checks) {
  for (const std::string& e : checks)
    if (!e.empty()) return e;
  return "";
}

std::string parse_floor(const json::Value& v, FloorLook* f) {
  const char* w = "look.floor";
  if (!v.is_object()) return "look.floor must be an object";
  if (std::string e = known_keys(v, w, {"material", "colour", "accent", "size", "length", "line", "variation", "gloss"});
      !e.empty())
    return e;
  if (const json::Value* m = v.find("material")) {
    const std::string name = m->is_string() ? m->string : "";
    if (name == "plain") f->material = FloorLook::Material::kPlain;
    else if (name == "tiles") f->material = FloorLook::Material::kTiles;
    else if (name == "planks") f->material = FloorLook::Material::kPlanks;
    else if (name == "carpet") f->material = FloorLook::Material::kCarpet;
    else if (name == "glossy") {  // a plain floor that reflects
      f->material = FloorLook::Material::kPlain;
      f->gloss = 0.35;
    } else
      return "look.floor.material must be \"plain\", \"tiles\", \"planks\", \"carpet\" or \"glossy\"";
  } else {
    f->material = FloorLook::Material::kPlain;  // a floor object without one: plain, in its colour
  }
  if (f->material == FloorLook::Material::kPlanks) f->size_m = 0.14, f->line_m = 0.002;
  if (f->material == FloorLook::Material::kCarpet) f->size_m = 0.4, f->variation = 0.03;
  return first({colour(v, w, "colour", &f->colour), colour(v, w, "accent", &f->accent),
                number(v, w, "size", 0.02, 5.0, &f->size_m), number(v, w, "length", 0.1, 10.0, &f->length_m),
                number(v, w, "line", 0.0, 0.05, &f->line_m), number(v, w, "variation", 0.0, 0.5, &f->variation),
                number(v, w, "gloss", 0.0, 1.0, &f->gloss)});
}

std::string parse_walls(const json::Value& v, WallLook* wl) {
  const char* w = "look.walls";
  if (!v.is_object()) return "look.walls must be an object";
  if (std::string e = known_keys(v, w, {"colour", "skirting", "skirting_colour"}); !e.empty()) return e;
  wl->painted = v.find("colour") != nullptr;
  return first({colour(v, w, "colour", &wl->colour), number(v, w, "skirting", 0.0, 0.5, &wl->skirting_m),
                colour(v, w, "skirting_colour", &wl->skirting_colour)});
}

std::string parse_lights(const json::Value& v, std::vector<LightLook>* out) {
  if (!v.is_array() || v.array.size() > 8) return "look.lights must be an array of at most 8 {x, y, z, power, radius}";
  for (size_t k = 0; k < v.array.size(); ++k) {
    const json::Value& l = v.array[k];
    const std::string where = "look.lights[" + std::to_string(k) + "]";
    if (!l.is_object()) return where + " must be an object {x, y, z, power, radius}";
    if (std::string e = known_keys(l, where.c_str(), {"x", "y", "z", "power", "radius"}); !e.empty()) return e;
    if (!l.find("x") || !l.find("y")) return where + " needs x and y (m)";
    LightLook light;
    const char* w = where.c_str();
    if (std::string e = first({number(l, w, "x", -1e5, 1e5, &light.x_m), number(l, w, "y", -1e5, 1e5, &light.y_m),
                               number(l, w, "z", 0.5, 20.0, &light.z_m), number(l, w, "power", 0.0, 5.0, &light.power),
                               number(l, w, "radius", 0.0, 2.0, &light.radius_m)});
        !e.empty())
      return e;
    out->push_back(light);
  }
  return "";
}

std::string parse_camera(const json::Value& v, CameraLook* c) {
  const char* w = "look.camera";
  if (!v.is_object()) return "look.camera must be an object";
  if (std::string e = known_keys(v, w, {"vignetting", "uneven", "auto_exposure", "ae_target", "ae_rate", "shutter_ms",
                                        "sensor_noise"});
      !e.empty())
    return e;
  return first({number(v, w, "vignetting", 0.0, 0.9, &c->vignetting), number(v, w, "uneven", 0.0, 0.5, &c->uneven),
                flag(v, w, "auto_exposure", &c->auto_exposure), number(v, w, "ae_target", 10.0, 245.0, &c->ae_target),
                number(v, w, "ae_rate", 0.01, 1.0, &c->ae_rate), number(v, w, "shutter_ms", 0.0, 200.0, &c->shutter_ms),
                flag(v, w, "sensor_noise", &c->sensor_noise)});
}

}  // namespace

std::string parse_look(const json::Value& v, Look* out) {
  *out = Look{};
  if (!v.is_object()) return "look must be an object {floor, walls, lights, ambient, cart_height, ceiling, camera}";
  if (std::string e = known_keys(v, "look", {"floor", "walls", "lights", "ambient", "cart_height", "ceiling", "camera"});
      !e.empty())
    return e;
  if (const json::Value* f = v.find("floor"))
    if (std::string e = parse_floor(*f, &out->floor); !e.empty()) return e;
  if (const json::Value* w = v.find("walls"))
    if (std::string e = parse_walls(*w, &out->walls); !e.empty()) return e;
  if (const json::Value* l = v.find("lights"))
    if (std::string e = parse_lights(*l, &out->lights); !e.empty()) return e;
  if (const json::Value* c = v.find("camera"))
    if (std::string e = parse_camera(*c, &out->camera); !e.empty()) return e;
  return first({number(v, "look", "ambient", 0.0, 2.0, &out->ambient),
                number(v, "look", "cart_height", 0.0, 2.0, &out->cart_height_m),
                colour(v, "look", "ceiling", &out->ceiling)});
}

}  // namespace cart2d
