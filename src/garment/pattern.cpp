// The pattern reader: GarmentCode and Garment-Pattern-Generator JSON specifications
// (docs/patterns.md, "Pattern files").
#include "weft/garment/pattern.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "weft/input_file.hpp"
#include "io/json_util.hpp"
#include "weft/error.hpp"
#include "weft/scene.hpp"

namespace weft {

namespace {

using nlohmann::json;
using json_util::describe;

/// Largest magnitude of a number in file units; beyond it a file is surely broken.
constexpr double kMaxCoordinate = 1e9;
/// Farthest a panel's corners and control points may lie from its origin, and the largest
/// circle radius and translation: a garment's panels measure a few metres, and this bound
/// keeps the samples of any accepted curve at a target length of millimetres in memory.
constexpr double kMaxExtent_m = 100;
/// Curved edges are sampled at about this length for the self-intersection check, within
/// [kMinCheckSegments, kMaxCheckSegments] segments per edge.
constexpr double kCheckSegment_m = 0.002;
constexpr int kMinCheckSegments = 16;
constexpr int kMaxCheckSegments = 4000;

/// A place in the file for messages: "FILE: panel 'front': edge 3".
struct Place {
  std::string text;
  Place at(const std::string& more) const { return Place{text + ": " + more}; }
  /// A key below a JSON path ("FILE: key a.b" -> "FILE: key a.b.KEY").
  Place key(const std::string& name) const { return Place{text + "." + name}; }
  [[noreturn]] void fail(const std::string& message) const { throw InputError(text + ": " + message); }
};

double finite_number(const json& v, const Place& place, const char* expected) {
  if (!v.is_number()) place.fail(std::string("expected ") + expected + ", got " + describe(v));
  const double x = v.get<double>();
  if (!(std::abs(x) <= kMaxCoordinate))
    place.fail("value " + v.dump() + " is out of range " + json_util::range_text(-kMaxCoordinate, kMaxCoordinate, ""));
  return x;
}

/// An [x, y] pair of numbers.
Vec2 pair_of_numbers(const json& v, const Place& place) {
  if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
    place.fail("expected [x, y] (two numbers), got " + describe(v));
  return Vec2(finite_number(v[0], place, "a number"), finite_number(v[1], place, "a number"));
}

Vec3 three_numbers(const json& v, const Place& place) {
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    place.fail("expected [x, y, z] (three numbers), got " + describe(v));
  return Vec3(finite_number(v[0], place, "a number"), finite_number(v[1], place, "a number"),
              finite_number(v[2], place, "a number"));
}

/// `p` (metres) within kMaxExtent_m of the panel's origin.
Vec2 within_extent(const Vec2& p, const Place& place, const char* what) {
  if (!(p.norm() <= kMaxExtent_m))
    place.fail(std::string(what) + " (" + json(p.x()).dump() + ", " + json(p.y()).dump() + ") m lies farther than " +
               json(kMaxExtent_m).dump() + " m from the panel's origin");
  return p;
}

/// A flag written as true/false or 1/0.
bool flag(const json& v, const Place& place) {
  if (v.is_boolean()) return v.get<bool>();
  const auto i = json_util::integer_value(v);
  if (!i || (*i != 0 && *i != 1)) place.fail("expected true, false, 1 or 0, got " + describe(v));
  return *i == 1;
}

/// The file's units and how curvature control points are written.
struct Units {
  double metres_per_unit = 0.01;
  bool relative_controls = true;
};

/// A control point in panel coordinates (metres) from the file's form: relative ones are
/// (along, across) the edge, both in edge lengths, "across" to the left of the edge
/// (the edge direction turned counter-clockwise by 90 degrees); absolute ones are in file units.
Vec2 control_point(const json& v, const Vec2& start, const Vec2& end, const Units& units, const Place& place) {
  const Vec2 p = pair_of_numbers(v, place);
  if (!units.relative_controls) return within_extent(units.metres_per_unit * p, place, "control point");
  const Vec2 along = end - start;
  const Vec2 left(-along.y(), along.x());
  return within_extent(start + p.x() * along + p.y() * left, place, "control point");
}

/// An arc from GarmentCode's circle parameters: radius, large-arc flag, and whether the arc
/// bulges to the right of the edge (then it runs counter-clockwise around its centre).
void set_arc(EdgeCurve& c, const json& params, double metres_per_unit, const Place& place) {
  if (!params.is_array() || params.size() != 3)
    place.fail("expected [radius, large_arc, right], got " + describe(params));
  const double radius_m = finite_number(params[0], place.at("radius"), "a number") * metres_per_unit;
  const bool large = flag(params[1], place.at("large_arc"));
  const bool right = flag(params[2], place.at("right"));
  const Vec2 chord = c.end - c.start;
  if (!(radius_m <= kMaxExtent_m))
    place.fail("radius " + params[0].dump() + " is larger than " + json(kMaxExtent_m).dump() + " m");
  const double half_chord_m = 0.5 * chord.norm();
  // A radius a rounding error short of half the chord is the half circle it was meant to be.
  if (!(radius_m >= half_chord_m * (1 - 1e-9)))
    place.fail("radius " + params[0].dump() + " is shorter than half the distance between the edge's endpoints (" +
               nlohmann::json(half_chord_m / metres_per_unit).dump() + ")");
  const double ratio = std::min(1.0, half_chord_m / radius_m);
  const double half_angle = std::asin(ratio);
  const double apothem_m = radius_m * std::cos(half_angle);
  const Vec2 left = Vec2(-chord.y(), chord.x()) / chord.norm();
  // A right-bulging minor arc has its centre on the left of the chord; a major arc, across.
  const double side = (right != large) ? 1.0 : -1.0;
  c.kind = CurveKind::kArc;
  c.center = 0.5 * (c.start + c.end) + side * apothem_m * left;
  c.radius_m = radius_m;
  const Vec2 r0 = c.start - c.center;
  c.start_angle_rad = std::atan2(r0.y(), r0.x());
  const double sweep = large ? 2 * M_PI - 2 * half_angle : 2 * half_angle;
  c.sweep_rad = right ? sweep : -sweep;
}

/// The curve of an edge from its "curvature" value (absent or null: straight).
EdgeCurve edge_curve(const json* curvature, const Vec2& start_m, const Vec2& end_m, const Units& units,
                     const Place& place) {
  EdgeCurve c;
  c.start = start_m;
  c.end = end_m;
  if (!curvature || curvature->is_null()) return c;
  const Place here = place.at("curvature");
  const json& v = *curvature;
  if (v.is_array()) {
    c.kind = CurveKind::kQuadratic;
    c.control[0] = control_point(v, start_m, end_m, units, here);
    return c;
  }
  if (!v.is_object() || !v.contains("type") || !v["type"].is_string())
    here.fail("expected [x, y] or an object with a type (quadratic, cubic or circle), got " + describe(v));
  const std::string type = v["type"].get<std::string>();
  if (!v.contains("params")) here.at("params").fail("missing");
  const json& params = v["params"];
  const Place at_params = here.at("params");
  if (type == "quadratic" || type == "cubic") {
    const size_t n = type == "quadratic" ? 1 : 2;
    if (!params.is_array() || params.size() != n)
      at_params.fail(std::string("expected ") + (n == 1 ? "[[x, y]]" : "[[x, y], [x, y]]") + " for a " + type +
                     " curve, got " + describe(params));
    c.kind = n == 1 ? CurveKind::kQuadratic : CurveKind::kCubic;
    for (size_t k = 0; k < n; ++k)
      c.control[k] = control_point(params[k], start_m, end_m, units, at_params);
    return c;
  }
  if (type == "circle") {
    set_arc(c, params, units.metres_per_unit, at_params);
    return c;
  }
  here.at("type").fail("unknown curve type \"" + type + "\" (expected quadratic, cubic or circle)");
}

Units read_units(const json& top, const std::string& file) {
  const Place place{file + ": key properties"};
  if (!top.contains("properties")) place.fail("missing (it gives units_in_meter)");
  const json& props = top["properties"];
  if (!props.is_object()) place.fail("expected an object, got " + describe(props));
  Units units;
  const Place at_u = place.key("units_in_meter");
  if (!props.contains("units_in_meter")) at_u.fail("missing");
  const json& u = props["units_in_meter"];
  if (!u.is_number() || !(u.get<double>() > 0) || !(u.get<double>() <= 1e9))
    at_u.fail("expected a number in (0, 1e9] (file units in one metre), got " + describe(u));
  units.metres_per_unit = 1.0 / u.get<double>();
  if (props.contains("curvature_coords")) {
    const json& cc = props["curvature_coords"];
    if (cc == "relative") {
      units.relative_controls = true;
    } else if (cc == "absolute") {
      units.relative_controls = false;
    } else {
      place.key("curvature_coords").fail("expected \"relative\" or \"absolute\", got " +
                                                             describe(cc));
    }
  }
  return units;
}

/// A point where two segments of a polygon (numbered by their first points) meet.
Vec2 meeting_point(const std::vector<Vec2>& poly, const std::array<int, 2>& segments) {
  const size_t n = poly.size();
  const Vec2& a = poly[static_cast<size_t>(segments[0])];
  const Vec2& b = poly[(static_cast<size_t>(segments[0]) + 1) % n];
  const Vec2& c = poly[static_cast<size_t>(segments[1])];
  const Vec2& d = poly[(static_cast<size_t>(segments[1]) + 1) % n];
  const auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
  const double denominator = cross(b - a, d - c);
  if (denominator != 0) return a + std::clamp(cross(c - a, d - c) / denominator, 0.0, 1.0) * (b - a);
  // Parallel segments that meet overlap: an endpoint of one lies on the other.
  for (const Vec2* p : {&c, &d})
    if ((*p - a).dot(*p - b) <= 0) return *p;
  return a;
}

/// The panel's outline must be a simple closed curve enclosing some area. Returns whether
/// its edges run clockwise. Curved edges are sampled finely here, whatever mesh size a
/// garment later uses.
bool check_outline(const Panel& panel, const Place& place) {
  std::vector<int> segments;
  for (const PanelEdge& e : panel.edges) {
    const int n = e.curve.kind == CurveKind::kStraight
                      ? 1
                      : std::clamp(segment_count(e.curve, kCheckSegment_m), kMinCheckSegments, kMaxCheckSegments);
    segments.push_back(n);
  }
  const SampledOutline outline = panel_outline(panel, segments);
  const int n_points = static_cast<int>(outline.points_m.size());
  const std::array<int, 2> hit = polygon_self_intersection(outline.points_m);
  if (hit[0] >= 0) {
    // The edges the two crossing segments belong to.
    auto edge_of = [&](int segment) {
      for (size_t e = 0; e < outline.edges.size(); ++e) {
        const int offset = (segment - outline.edges[e].first + n_points) % n_points;
        if (offset < outline.edges[e].segments) return static_cast<int>(e);
      }
      return -1;
    };
    const Vec2 p = meeting_point(outline.points_m, hit);
    place.fail("outline crosses itself: edge " + std::to_string(edge_of(hit[0])) + " meets edge " +
               std::to_string(edge_of(hit[1])) + " near (" + json(p.x()).dump() + ", " + json(p.y()).dump() +
               ") m");
  }
  const double area_m2 = polygon_area_m2(outline.points_m);
  if (!(std::abs(area_m2) > 0)) place.fail("outline encloses no area");
  return outline.reversed ? area_m2 > 0 : area_m2 < 0;
}

Panel read_panel(const std::string& name, const json& j, const Units& units, bool normalize_translation,
                 const std::string& file) {
  const Place place{file + ": panel '" + name + "'"};
  if (!j.is_object()) place.fail("expected an object, got " + describe(j));
  Panel panel;
  panel.name = name;
  if (!j.contains("vertices")) place.at("vertices").fail("missing");
  const json& vertices = j["vertices"];
  if (!vertices.is_array() || vertices.empty())
    place.at("vertices").fail("expected an array of [x, y] points, got " + describe(vertices));
  for (size_t i = 0; i < vertices.size(); ++i) {
    const Place at_vertex = place.at("vertex " + std::to_string(i));
    panel.vertices_m.push_back(within_extent(units.metres_per_unit * pair_of_numbers(vertices[i], at_vertex), at_vertex, "the point"));
  }
  if (j.contains("translation")) {
    panel.translation_m = units.metres_per_unit * three_numbers(j["translation"], place.at("translation"));
    if (!(panel.translation_m.lpNorm<Eigen::Infinity>() <= kMaxExtent_m))
      place.at("translation").fail("expected coordinates within " + json(kMaxExtent_m).dump() + " m, got " +
                                   describe(j["translation"]));
  }
  if (j.contains("rotation")) panel.rotation_deg = three_numbers(j["rotation"], place.at("rotation"));

  if (!j.contains("edges")) place.at("edges").fail("missing");
  const json& edges = j["edges"];
  if (!edges.is_array() || edges.empty()) place.at("edges").fail("expected an array of edges, got " + describe(edges));
  const long n_vertices = static_cast<long>(panel.vertices_m.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    const Place at_edge = place.at("edge " + std::to_string(i));
    const json& e = edges[i];
    if (!e.is_object()) at_edge.fail("expected an object, got " + describe(e));
    if (!e.contains("endpoints")) at_edge.at("endpoints").fail("missing");
    const json& ends = e["endpoints"];
    std::array<long, 2> idx{};
    bool ok = ends.is_array() && ends.size() == 2;
    for (size_t k = 0; ok && k < 2; ++k) {
      const auto v = json_util::integer_value(ends[k]);
      ok = v && *v >= 0 && *v < n_vertices;
      if (ok) idx[k] = *v;
    }
    if (!ok)
      at_edge.at("endpoints").fail("expected [start, end], two vertex indices in [0, " + std::to_string(n_vertices - 1) +
                                   "], got " + describe(ends));
    PanelEdge edge;
    edge.start_vertex = static_cast<int>(idx[0]);
    edge.end_vertex = static_cast<int>(idx[1]);
    const Vec2& a = panel.vertices_m[static_cast<size_t>(idx[0])];
    const Vec2& b = panel.vertices_m[static_cast<size_t>(idx[1])];
    if (!((a - b).norm() > 0))
      at_edge.at("endpoints").fail("the edge starts and ends at the same point (vertices " + std::to_string(idx[0]) +
                                   " and " + std::to_string(idx[1]) + ")");
    edge.curve = edge_curve(e.contains("curvature") ? &e["curvature"] : nullptr, a, b, units, at_edge);
    if (i > 0 && panel.edges.back().end_vertex != edge.start_vertex)
      at_edge.fail("starts at vertex " + std::to_string(edge.start_vertex) + " but edge " + std::to_string(i - 1) +
                   " ends at vertex " + std::to_string(panel.edges.back().end_vertex) +
                   " (the edges must form a closed loop in order)");
    panel.edges.push_back(edge);
  }
  if (panel.edges.back().end_vertex != panel.edges.front().start_vertex)
    place.at("edge " + std::to_string(panel.edges.size() - 1))
        .fail("ends at vertex " + std::to_string(panel.edges.back().end_vertex) + " but edge 0 starts at vertex " +
              std::to_string(panel.edges.front().start_vertex) + " (the edges must form a closed loop)");

  if (normalize_translation) {
    // The format's option: the panel's origin moves to the mean of its corners, and the
    // translation takes up the difference in x and y.
    Vec2 mean = Vec2::Zero();
    for (const Vec2& v : panel.vertices_m) mean += v;
    mean /= static_cast<double>(panel.vertices_m.size());
    for (Vec2& v : panel.vertices_m) v -= mean;
    for (PanelEdge& e : panel.edges) {
      EdgeCurve& c = e.curve;
      for (Vec2* p : {&c.start, &c.end, &c.control[0], &c.control[1], &c.center}) *p -= mean;
    }
    panel.translation_m.x() += mean.x();
    panel.translation_m.y() += mean.y();
  }
  panel.clockwise = check_outline(panel, place);
  return panel;
}

/// "FILE: key pattern.stitches[i][k]".
Place stitch_place(const std::string& file, size_t i, long k) {
  std::string text = file + ": key pattern.stitches[" + std::to_string(i) + "]";
  if (k >= 0) text += "[" + std::to_string(k) + "]";
  return Place{text};
}

StitchSide read_side(const json& j, const std::map<std::string, int>& panel_index, const std::vector<Panel>& panels,
                     const Place& place) {
  if (!j.is_object() || !j.contains("panel") || !j.contains("edge"))
    place.fail("expected {\"panel\": NAME, \"edge\": INDEX}, got " + describe(j));
  const json& name = j["panel"];
  if (!name.is_string()) place.key("panel").fail("expected a panel name, got " + describe(name));
  const auto it = panel_index.find(name.get<std::string>());
  if (it == panel_index.end()) place.key("panel").fail("no panel named '" + name.get<std::string>() + "'");
  StitchSide side;
  side.panel = it->second;
  const Panel& panel = panels[static_cast<size_t>(side.panel)];
  const auto edge = json_util::integer_value(j["edge"]);
  if (!edge) place.key("edge").fail("expected an edge index, got " + describe(j["edge"]));
  if (*edge < 0 || *edge >= static_cast<long>(panel.edges.size()))
    place.key("edge").fail("panel '" + panel.name + "' has no edge " + std::to_string(*edge) + " (its edges are 0 to " +
                          std::to_string(panel.edges.size() - 1) + ")");
  side.edge = static_cast<int>(*edge);
  return side;
}

std::string pattern_name(const std::string& file) {
  std::string name = file.substr(file.find_last_of('/') == std::string::npos ? 0 : file.find_last_of('/') + 1);
  const auto strip = [&](const std::string& suffix) {
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
      name.resize(name.size() - suffix.size());
  };
  strip(".json");
  strip("_specification");
  return name;
}

}  // namespace

Pattern parse_pattern(const std::string& text, const std::string& file) {
  const json top = json_util::parse_json(text, file);
  if (!top.is_object()) Place{file + ": top level"}.fail("expected an object, got " + describe(top));
  const Units units = read_units(top, file);
  bool normalize_translation = false;
  if (top["properties"].contains("normalize_panel_translation"))
    normalize_translation = flag(top["properties"]["normalize_panel_translation"],
                                 Place{file + ": key properties.normalize_panel_translation"});

  if (!top.contains("pattern")) Place{file + ": key pattern"}.fail("missing");
  const json& pat = top["pattern"];
  if (!pat.is_object()) Place{file + ": key pattern"}.fail("expected an object, got " + describe(pat));
  if (!pat.contains("panels")) Place{file + ": key pattern.panels"}.fail("missing");
  const json& panels = pat["panels"];
  if (!panels.is_object() || panels.empty())
    Place{file + ": key pattern.panels"}.fail("expected an object of named panels, got " + describe(panels));

  // Panel order: the file's panel_order when present (it must name each panel once), else
  // by name.
  std::vector<std::string> order;
  if (pat.contains("panel_order")) {
    const Place at_order{file + ": key pattern.panel_order"};
    const json& po = pat["panel_order"];
    if (!po.is_array()) at_order.fail("expected an array of panel names, got " + describe(po));
    std::set<std::string> seen;
    for (const json& n : po) {
      if (!n.is_string()) at_order.fail("expected panel names, got " + describe(n));
      const std::string s = n.get<std::string>();
      if (!panels.contains(s)) at_order.fail("no panel named '" + s + "'");
      if (!seen.insert(s).second) at_order.fail("panel '" + s + "' is listed twice");
      order.push_back(s);
    }
    for (auto it = panels.begin(); it != panels.end(); ++it)
      if (!seen.count(it.key())) at_order.fail("panel '" + it.key() + "' is missing from the order");
  } else {
    for (auto it = panels.begin(); it != panels.end(); ++it) order.push_back(it.key());
  }

  Pattern pattern;
  pattern.name = pattern_name(file);
  pattern.file = file;
  std::map<std::string, int> panel_index;
  for (const std::string& name : order) {
    panel_index[name] = static_cast<int>(pattern.panels.size());
    pattern.panels.push_back(read_panel(name, panels[name], units, normalize_translation, file));
  }

  if (pat.contains("stitches")) {
    const json& stitches = pat["stitches"];
    if (!stitches.is_array())
      Place{file + ": key pattern.stitches"}.fail("expected an array of stitches, got " + describe(stitches));
    for (size_t i = 0; i < stitches.size(); ++i) {
      const json& s = stitches[i];
      const Place place = stitch_place(file, i, -1);
      if (!s.is_array() || s.size() < 2 || s.size() > 3)
        place.fail("expected [side, side] or [side, side, \"right_wrong\"], got " + describe(s));
      Stitch stitch;
      stitch.a = read_side(s[0], panel_index, pattern.panels, stitch_place(file, i, 0));
      stitch.b = read_side(s[1], panel_index, pattern.panels, stitch_place(file, i, 1));
      if (s.size() == 3) {
        if (s[2] != "right_wrong") stitch_place(file, i, 2).fail("expected \"right_wrong\", got " + describe(s[2]));
        stitch.same_direction = true;
      }
      if (stitch.a.panel == stitch.b.panel && stitch.a.edge == stitch.b.edge)
        place.fail("sews edge " + std::to_string(stitch.a.edge) + " of panel '" +
                   pattern.panels[static_cast<size_t>(stitch.a.panel)].name + "' to itself");
      pattern.stitches.push_back(stitch);
    }
  }
  return pattern;
}

Pattern load_pattern(const std::string& path) { return parse_pattern(read_input_file(path, "pattern file"), path); }

void check_scene_panels(const Scene& scene, const Pattern& pattern) {
  if (!scene.cloth.garment) return;
  for (const auto& [name, placement] : scene.cloth.garment->panels) {
    bool found = false;
    for (const Panel& panel : pattern.panels) found = found || panel.name == name;
    if (!found)
      throw InputError((scene.file.empty() ? std::string("scene") : scene.file) + ": key cloth.mesh.pattern.panels." +
                       name + ": the pattern " + scene.cloth.garment->pattern_file + " has no panel '" + name + "'");
  }
}

}  // namespace weft
