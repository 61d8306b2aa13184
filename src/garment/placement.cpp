#include "weft/garment/placement.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>

#include "collision/colliders.hpp"
#include "weft/error.hpp"

namespace weft {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// An elliptic cylinder about a body part: points O + h a + r1 cos(phi) e1 + r2 sin(phi) e2,
/// with e1 x e2 = a, so that phi grows the way a x (outward normal) points.
struct Cylinder {
  Vec3 origin = Vec3::Zero(), axis = Vec3::UnitY(), e1 = Vec3::UnitZ(), e2 = Vec3::UnitX();
  double r1 = 0.1, r2 = 0.1;
  std::vector<double> arc;  ///< arc length at phi = 2 pi k / (arc.size() - 1)

  void tabulate() {
    const int n = 2048;
    arc.assign(n + 1, 0.0);
    for (int k = 1; k <= n; ++k) {
      const double p0 = 2 * kPi * (k - 1) / n, p1 = 2 * kPi * k / n;
      const Vec2 a(r1 * std::cos(p0), r2 * std::sin(p0)), b(r1 * std::cos(p1), r2 * std::sin(p1));
      arc[k] = arc[k - 1] + (b - a).norm();
    }
  }
  double girth() const { return arc.back(); }
  double arc_at(double phi) const {
    phi = std::fmod(phi, 2 * kPi);
    if (phi < 0) phi += 2 * kPi;
    const double f = phi / (2 * kPi) * (arc.size() - 1);
    const size_t k = std::min(static_cast<size_t>(f), arc.size() - 2);
    return arc[k] + (f - k) * (arc[k + 1] - arc[k]);
  }
  double phi_at(double s) const {
    const double L = girth();
    s = std::fmod(s, L);
    if (s < 0) s += L;
    const size_t k = std::min(static_cast<size_t>(std::upper_bound(arc.begin(), arc.end(), s) - arc.begin()),
                              arc.size() - 1);
    const size_t j = k == 0 ? 0 : k - 1;
    const double span = arc[j + 1] - arc[j];
    const double f = span > 0 ? (s - arc[j]) / span : 0.0;
    return 2 * kPi * (j + f) / (arc.size() - 1);
  }
  Vec3 point(double h, double phi) const {
    return origin + h * axis + r1 * std::cos(phi) * e1 + r2 * std::sin(phi) * e2;
  }
  double phi_of_direction(const Vec3& n) const { return std::atan2(n.dot(e2), n.dot(e1)); }
};

/// A circular cone about a vertical axis, opening downwards, for a flared skirt: radius r0 at
/// height `top` (the waist), growing by `slope` per metre down. Cones are developable: a flat
/// panel laid on the cone's development (a sector about its apex) keeps every length.
struct Cone {
  Vec3 origin = Vec3::Zero();  ///< a point of the axis at height 0
  double top = 0, r0 = 0.1, slope = 0.2;
  double sin_a() const { return slope / std::sqrt(1 + slope * slope); }
  /// Slant distance from the apex to the top circle.
  double rho_top() const { return r0 / sin_a(); }
  /// The point at slant distance rho from the apex, at development angle theta (radians of the
  /// flat sector: azimuth = theta / sin a, 0 the front, growing towards +x).
  Vec3 point(double rho, double theta) const {
    const double sa = sin_a(), ca = 1 / std::sqrt(1 + slope * slope);
    const double phi = theta / sa, y_apex = top + r0 / slope;
    return origin + Vec3(rho * sa * std::sin(phi), y_apex - rho * ca, rho * sa * std::cos(phi));
  }
  /// Where a panel point lands whose flat offset is `s` across the panel (from its middle
  /// line, at angle theta_c) and `down` along it below the top circle: the panel is laid in
  /// the development with its middle line on the ray theta_c, rigidly, then rolled up.
  Vec3 roll(double theta_c, double s, double down) const {
    const double along = rho_top() + down;
    return point(std::hypot(along, s), theta_c + std::atan2(s, along));
  }
};

Mat3 euler_xyz(const Vec3& deg) {
  const Vec3 r = deg * (kPi / 180.0);
  return (Eigen::AngleAxisd(r.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(r.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

bool contains(const std::string& s, const char* word) { return s.find(word) != std::string::npos; }

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// The part a panel goes around, from its name and (for the side) where the file places it.
BodyPart guess_part(const std::string& name, double file_x) {
  const std::string n = lower(name);
  const bool left = file_x > 0;  // the wearer's left is +x (the body faces +z)
  if (contains(n, "sleeve")) return left ? BodyPart::kLeftArm : BodyPart::kRightArm;
  if (contains(n, "pant") || contains(n, "leg") || contains(n, "trouser"))
    return left ? BodyPart::kLeftLeg : BodyPart::kRightLeg;
  if (contains(n, "hood")) return BodyPart::kHead;
  return BodyPart::kTorso;
}

Vec3 joint(const Rig& rig, const char* bone, bool tail = false) {
  const int b = rig.find(bone);
  if (b < 0) throw InputError(std::string("the body's rig has no bone ") + bone);
  return tail ? rig.tail_bind[b] : rig.head_bind[b];
}

/// A frame (e1, e2) about `axis` with e1 as near `front` as it goes and e1 x e2 = axis.
void set_frame(Cylinder& c, const Vec3& axis, const Vec3& front) {
  c.axis = axis.normalized();
  c.e1 = (front - front.dot(c.axis) * c.axis).normalized();
  c.e2 = c.axis.cross(c.e1);
}

/// Semi-axes (r1, r2) of the smallest ellipse of the cylinder's frame (with the aspect of the
/// points' extents) holding the body's vertices whose axial coordinate lies in [h0, h1] and
/// that are within `reach` of the axis, centred where those points are.
void fit_to_body(Cylinder& c, const Points& body, double h0, double h1, double reach) {
  std::vector<Vec2> q;
  for (Eigen::Index i = 0; i < body.rows(); ++i) {
    const Vec3 d = body.row(i).transpose() - c.origin;
    const double h = d.dot(c.axis);
    if (h < h0 || h > h1) continue;
    const Vec2 p(d.dot(c.e1), d.dot(c.e2));
    if (p.norm() <= reach) q.push_back(p);
  }
  if (q.empty()) return;
  Vec2 lo = q[0], hi = q[0];
  for (const Vec2& p : q) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec2 mid = 0.5 * (lo + hi), half = (0.5 * (hi - lo)).cwiseMax(Vec2::Constant(1e-3));
  c.origin += mid.x() * c.e1 + mid.y() * c.e2;
  double scale = 0;
  for (const Vec2& p : q) scale = std::max(scale, ((p - mid).array() / half.array()).matrix().norm());
  c.r1 = scale * half.x();
  c.r2 = scale * half.y();
}

/// A pattern that is a skirt: its name says so, or every panel about the torso is a skirt's.
bool is_skirt(const Pattern& pattern, const std::vector<int>& torso_panels) {
  if (contains(lower(pattern.name), "skirt")) return true;
  for (int p : torso_panels)
    if (!contains(lower(pattern.panels[p].name), "skirt")) return false;
  return !torso_panels.empty();
}

/// The cone for a skirt whose panels, in flat coordinates (s across each panel from its middle,
/// h up along it), sum to a width growing down the skirt (each panel's top at the waist): its slope
/// makes the girth grow as the panels' summed width does (times the allowance), from their
/// widths in the top and bottom tenth of each panel; its radius at the top is as small as
/// keeps `clearance` from every body vertex within 0.35 m of the axis down the skirt's length.
Cone skirt_cone(const std::vector<std::vector<Vec2>>& panels, double span, const Vec3& origin,
                double waist, const Points& body, double clearance, double allowance) {
  double top_width = 0, bottom_width = 0, top_depth = 0, bottom_depth = 0;
  for (const std::vector<Vec2>& pts : panels) {
    double lo = 1e30, hi = -1e30;
    for (const Vec2& q : pts) {
      lo = std::min(lo, q.y());
      hi = std::max(hi, q.y());
    }
    const double band = 0.1 * (hi - lo);
    double t0 = 1e30, t1 = -1e30, b0 = 1e30, b1 = -1e30;
    for (const Vec2& q : pts) {
      if (q.y() >= hi - band) t0 = std::min(t0, q.x()), t1 = std::max(t1, q.x());
      if (q.y() <= lo + band) b0 = std::min(b0, q.x()), b1 = std::max(b1, q.x());
    }
    top_width += t1 - t0;
    bottom_width += b1 - b0;
    top_depth += 0.5 * band / panels.size();
    bottom_depth += (hi - lo - 0.5 * band) / panels.size();
  }
  Cone cone;
  cone.origin = Vec3(origin.x(), 0, origin.z());
  cone.top = waist;
  const double run = std::max(bottom_depth - top_depth, 0.1 * span);
  cone.slope = std::max(0.02, allowance * (bottom_width - top_width) / (2 * kPi * run));
  cone.r0 = allowance * top_width / (2 * kPi) - cone.slope * top_depth;
  for (Eigen::Index i = 0; i < body.rows(); ++i) {
    const double down = waist - body(i, 1);
    if (down < -0.02 || down > span) continue;
    const double r = std::hypot(body(i, 0) - origin.x(), body(i, 2) - origin.z());
    if (r <= 0.35) cone.r0 = std::max(cone.r0, r + clearance - cone.slope * std::max(0.0, down));
  }
  return cone;
}

}  // namespace

BindBody load_bind_body(BodyColliderSpec spec, double hold_s) {
  if (!(hold_s > 0)) throw std::invalid_argument("load_bind_body: the hold must be positive");
  spec.bind_pose_hold = std::max(spec.bind_pose_hold, hold_s);
  WalkingBody walker(spec);
  BindBody body;
  walker.positions(0.0, body.positions);
  body.triangles = walker.triangles();
  body.rig = walker.rig();
  const Vec3 shift = (body.positions.row(0) - walker.bind_positions().row(0)).transpose();
  for (int b = 0; b < body.rig.bone_count(); ++b) {
    body.rig.head_bind[b] += shift;
    body.rig.tail_bind[b] += shift;
  }
  body.spec = spec;
  // The legs apart: every bone below each hip turned about the forward axis through that hip.
  std::vector<BonePose> poses;
  walker.bone_poses(0.0, poses);
  body.legs_apart_rig = body.rig;
  Rig& apart = body.legs_apart_rig;
  for (const auto& [hip_bone, side] : {std::pair{"LeftUpLeg", 1.0}, std::pair{"RightUpLeg", -1.0}}) {
    const int hip = apart.find(hip_bone);
    if (hip < 0) throw InputError(std::string("the body's rig has no bone ") + hip_bone);
    const Vec3 centre = body.rig.head_bind[hip];
    const Eigen::Quaterniond q(Eigen::AngleAxisd(side * kLegsApartDeg * kPi / 180, Vec3::UnitZ()));
    const BonePose turn{q, centre - q * centre};
    std::vector<char> below(apart.bone_count(), 0);
    for (int b = 0; b < apart.bone_count(); ++b) {
      below[b] = b == hip || (apart.parent[b] >= 0 && below[apart.parent[b]]);
      if (!below[b]) continue;
      poses[b] = turn * poses[b];
      apart.head_bind[b] = turn.apply(apart.head_bind[b]);
      apart.tail_bind[b] = turn.apply(apart.tail_bind[b]);
    }
  }
  walker.skin(poses, body.legs_apart_positions);
  return body;
}

double largest_seam_gap(const Points& positions, const std::vector<std::array<int, 2>>& pairs) {
  double gap = 0;
  for (const auto& p : pairs) gap = std::max(gap, (positions.row(p[0]) - positions.row(p[1])).norm());
  return gap;
}

namespace {

/// A panel as the pattern file places it.
struct FilePanel {
  Mat3 R;
  Vec3 t, centroid, outward;
  BodyPart part;
};

/// A point of a panel, as the file places the panel.
Vec3 file_point(const FilePanel& f, const Vec2& v) { return Vec3(f.R * Vec3(v.x(), v.y(), 0) + f.t); }

/// What a body part's panels go on.
struct PartGeometry {
  std::vector<int> panels;
  Vec3 file_axis = Vec3::UnitY(), file_origin = Vec3::Zero();
  Cylinder cyl;
  double shift = 0;  ///< added to the file's axial coordinate
  std::optional<Cone> cone;  ///< a skirt's flared panels go on this cone instead
  /// A hood's panels keep their place in the file against the torso, moved by this.
  std::optional<Vec3> file_offset;
  /// Trousers: both legs' panels on one cone about the hips, each panel's edge nearest the
  /// body's middle (in the file) put beside the middle line, kSideGap_m / 2 from it.
  bool trousers = false;
};

/// A part's panels in flat coordinates (across each panel from its centroid, up along the
/// part's axis), their widths summed and their extent along the file's axis.
struct PartPanels {
  std::vector<std::vector<Vec2>> flat;
  double h_lo = 1e30, h_hi = -1e30, width = 0;
};

/// A panel placed around its part: its extent around the girth (fractions of it) and along
/// the file's axis, and its layer.
struct Extent {
  BodyPart part;
  double s_lo, s_hi, h_lo, h_hi;
  int layer;
};

/// How a panel faces its part: its directions along the axis (ap) and across it (tau), the
/// angle about the cylinder its middle faces, and its shift along the axis.
struct PanelFrame {
  Vec3 ap, tau;
  double phi_n, shift;
};

// Panels of one part that would lie on each other (the overlapping fronts of a jacket) go
// on layers further out, kLayer_m apart, each its own cylinder.
constexpr double kLayer_m = 0.008;
// Panels of one part and layer that meet edge on edge around the girth (the two fronts of
// an open jacket, drawn touching in the file) are moved apart to leave this gap: their
// edges would otherwise lie on one line, vertex on vertex, which sewing cannot part (two
// coincident vertices have no direction to push apart) and which the garment keeps as
// intersecting triangles.
constexpr double kSideGap_m = 0.006;

// Throws InputError for an override naming a panel the pattern lacks.
void check_overrides(const Pattern& pattern, const PlacementOptions& options) {
  for (const auto& [name, o] : options.overrides) {
    bool found = false;
    for (const Panel& p : pattern.panels) found = found || p.name == name;
    if (!found) throw InputError(pattern.file + ": placement of panel '" + name + "': the pattern has no such panel");
  }
}

// Each panel as the file places it: its rotation and translation, centroid, outward normal, and
// the part it goes around (from its name and side, or an override).
std::vector<FilePanel> file_panels(const Pattern& pattern, const GarmentMesh& gm, const PlacementOptions& options) {
  const int np = static_cast<int>(pattern.panels.size());
  std::vector<FilePanel> fp(np);
  for (int p = 0; p < np; ++p) {
    const Panel& panel = pattern.panels[p];
    FilePanel& f = fp[p];
    f.R = euler_xyz(panel.rotation_deg);
    f.t = panel.translation_m;
    Vec3 c = Vec3::Zero();
    for (const Vec2& v : gm.panels[p].vertices_m) c += f.R * Vec3(v.x(), v.y(), 0) + f.t;
    f.centroid = c / std::max<size_t>(1, gm.panels[p].vertices_m.size());
    f.outward = f.R * Vec3(0, 0, panel.clockwise ? -1.0 : 1.0);
    f.part = guess_part(panel.name, f.centroid.x());
    auto o = options.overrides.find(panel.name);
    if (o != options.overrides.end() && o->second.part) f.part = *o->second.part;
  }
  return fp;
}

// Sets the file's axis of a part (up for the torso, legs and head; along an arm, its first
// sleeve panel's x axis, pointing away from the body) and a point on it (the middle of the
// part's panels across the axis); returns the panels measured across and along it. Throws
// InputError naming a panel that faces along the axis.
PartPanels measure_part(BodyPart part, PartGeometry& g, const Pattern& pattern, const GarmentMesh& gm,
                        const std::vector<FilePanel>& fp) {
  const bool arm = part == BodyPart::kLeftArm || part == BodyPart::kRightArm;
  const double side = (part == BodyPart::kLeftArm || part == BodyPart::kLeftLeg) ? 1.0 : -1.0;
  // (Pattern generators draw sleeves with the arm along x.)
  if (arm) {
    Vec3 a = fp[g.panels[0]].R * Vec3::UnitX();
    if (a.x() * side < 0) a = -a;
    g.file_axis = a.normalized();
  }
  Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30), mean = Vec3::Zero();
  for (int p : g.panels) {
    mean += fp[p].centroid;
    for (const Vec2& v : gm.panels[p].vertices_m) {
      lo = lo.cwiseMin(file_point(fp[p], v));
      hi = hi.cwiseMax(file_point(fp[p], v));
    }
  }
  g.file_origin = arm ? Vec3(mean / g.panels.size()) : Vec3(0.5 * (lo + hi));
  PartPanels out;
  for (int p : g.panels) {
    double s_lo = 1e30, s_hi = -1e30;
    const Vec3 n = fp[p].outward;
    const Vec3 ap = g.file_axis - g.file_axis.dot(n) * n;
    if (ap.norm() < 0.2)
      throw InputError(pattern.file + ": panel '" + pattern.panels[p].name + "' faces along the " +
                       body_part_name(part) + "'s axis and cannot be wrapped around it (set its part or angle)");
    const Vec3 tau = ap.normalized().cross(n);
    out.flat.emplace_back();
    for (const Vec2& v : gm.panels[p].vertices_m) {
      const Vec3 x = file_point(fp[p], v);
      out.flat.back().emplace_back((x - fp[p].centroid).dot(tau),
                                   (x - fp[p].centroid).dot(ap.normalized()) + fp[p].centroid.dot(g.file_axis));
      s_lo = std::min(s_lo, (x - fp[p].centroid).dot(tau));
      s_hi = std::max(s_hi, (x - fp[p].centroid).dot(tau));
      out.h_lo = std::min(out.h_lo, x.dot(g.file_axis));
      out.h_hi = std::max(out.h_hi, x.dot(g.file_axis));
    }
    out.width += s_hi - s_lo;
  }
  return out;
}

// The body's cylinder for a part, fitted to the body, and where its panels sit along it: a
// skirt on a cone from the waist, the torso from the base of the neck, a sleeve from where the
// torso's cylinder meets the arm, a hood above the crown (or flat beside the torso's neckline),
// trousers from the waist. `parts` holds the parts set before this one (the torso first).
void fit_part(BodyPart part, PartGeometry& g, const PartPanels& panels, std::map<BodyPart, PartGeometry>& parts,
              const Pattern& pattern, const BindBody& body, const PlacementOptions& options) {
  const bool arm = part == BodyPart::kLeftArm || part == BodyPart::kRightArm;
  const double side = (part == BodyPart::kLeftArm || part == BodyPart::kLeftLeg) ? 1.0 : -1.0;
  const Rig& rig = body.rig;
  const double clearance = options.clearance_m;
  Cylinder& c = g.cyl;
  const double span = panels.h_hi - panels.h_lo;
  if ((part == BodyPart::kTorso && is_skirt(pattern, g.panels)) || g.trousers) {
    // A skirt: its top at the waist, on a cone as flared as its panels. Trousers: both legs'
    // panels so, each beside the middle line; sewing closes the inseams between the legs. (On
    // a cylinder about each leg, as wide as the panels at the hip, the two legs' cylinders
    // crossed at the crotch.)
    c.origin = Vec3(0, 0, 0);
    set_frame(c, Vec3::UnitY(), Vec3::UnitZ());
    const double waist = joint(rig, "LowerBack", true).y();
    g.shift = waist - panels.h_hi;
    fit_to_body(c, body.positions, waist - span, waist, 0.35);
    g.cone = skirt_cone(panels.flat, span, c.origin, waist, body.positions, clearance, options.girth_allowance);
    // Trousers' cone round enough at every height for the panels side by side: a trouser
    // panel is widest at the crotch, below the waist's band that sets a skirt's cone.
    if (g.trousers) g.cone->r0 = std::max(g.cone->r0, options.girth_allowance * panels.width / (2 * kPi));
  } else if (part == BodyPart::kTorso) {
    // Vertical; the panels' top at the base of the neck, the fit taken below the armpits.
    c.origin = Vec3(0, 0, 0);
    set_frame(c, Vec3::UnitY(), Vec3::UnitZ());
    const double top = joint(rig, "Neck1").y() + clearance;
    const double armpit = joint(rig, "LeftArm").y() - 0.1;
    g.shift = top - panels.h_hi;
    fit_to_body(c, body.positions, std::min(top - span, armpit - 0.05), armpit, 0.35);
  } else if (arm) {
    const Vec3 shoulder = joint(rig, side > 0 ? "LeftArm" : "RightArm");
    const Vec3 wrist = joint(rig, side > 0 ? "LeftHand" : "RightHand");
    c.origin = shoulder;
    set_frame(c, wrist - shoulder, Vec3::UnitZ());
    // The sleeve starts where the torso's cylinder meets the arm.
    const Cylinder& torso = parts.count(BodyPart::kTorso) ? parts[BodyPart::kTorso].cyl : c;
    double start = 0;
    if (&torso != &c) {
      const double half_width = std::abs((Vec3::UnitX()).dot(torso.e2)) * torso.r2 + torso.origin.x() * side;
      start = std::max(0.0, (half_width - shoulder.x() * side) / std::abs(c.axis.x()));
    }
    g.shift = start - panels.h_lo;
    fit_to_body(c, body.positions, start, start + span, 0.12);
  } else if (part == BodyPart::kHead) {
    const Vec3 base = joint(rig, "Head"), crown = joint(rig, "Head", true);
    c.origin = Vec3(base.x(), 0, base.z());
    set_frame(c, Vec3::UnitY(), Vec3::UnitZ());
    g.shift = crown.y() + 0.1 - panels.h_hi;
    fit_to_body(c, body.positions, crown.y() + 0.1 - span, crown.y() + 0.1, 0.2);
    // With a torso: the hood's panels flat where the file puts them beside the torso's
    // neckline, the file moved as the torso's middle and top were.
    // Raised, where needed, so that its lowest point is a centimetre above the torso panels' top
    // (the base of the neck): hoody_mean's hood, laid with its neckline 3.5 cm below that top
    // beside the fronts' shoulders, tangled there in the first steps of sewing (the left front's
    // neckline stayed 14 mm open to the hood, 21 triangle pairs crossing); raised, it sews.
    if (parts.count(BodyPart::kTorso) && !parts[BodyPart::kTorso].cone) {
      const PartGeometry& t = parts[BodyPart::kTorso];
      const double torso_top = joint(rig, "Neck1").y() + clearance;
      const double raise = std::max(0.0, torso_top + 0.01 - (panels.h_lo + t.shift));
      g.file_offset =
          Vec3(t.cyl.origin.x() - t.file_origin.x(), t.shift + raise, t.cyl.origin.z() - t.file_origin.z());
    }
  } else {
    const Vec3 hip = joint(rig, side > 0 ? "LeftUpLeg" : "RightUpLeg");
    c.origin = Vec3(hip.x(), 0, hip.z());
    set_frame(c, Vec3::UnitY(), Vec3::UnitZ());
    const double waist = joint(rig, "LowerBack", true).y();
    g.shift = waist - panels.h_hi;
    fit_to_body(c, body.positions, waist - span, waist, 0.15);
  }
}

// Moves a part's cylinder out by the clearance, then widens it (keeping its aspect) to the
// girth its panels need: `allowance` times their summed width.
void widen_cylinder(Cylinder& c, double clearance, double allowance, double width) {
  c.r1 += clearance;
  c.r2 += clearance;
  c.tabulate();
  const double want = allowance * width;
  if (c.girth() < want) {
    const double f = want / c.girth();
    c.r1 *= f;
    c.r2 *= f;
    c.tabulate();
  }
}

// Each part's axis, cylinder (or cone) and panels, in BodyPart order.
std::map<BodyPart, PartGeometry> part_geometries(const Pattern& pattern, const GarmentMesh& gm, const BindBody& body,
                                                 const std::vector<FilePanel>& fp, const PlacementOptions& options) {
  std::map<BodyPart, PartGeometry> parts;
  for (size_t p = 0; p < fp.size(); ++p) parts[fp[p].part].panels.push_back(static_cast<int>(p));
  // Panels about both legs: trousers, placed together (the left leg's geometry serves both).
  const bool trousers = parts.count(BodyPart::kLeftLeg) && parts.count(BodyPart::kRightLeg);
  if (trousers) {
    std::vector<int>& both = parts[BodyPart::kLeftLeg].panels;
    const std::vector<int>& right = parts[BodyPart::kRightLeg].panels;
    both.insert(both.end(), right.begin(), right.end());
    std::sort(both.begin(), both.end());
    parts[BodyPart::kLeftLeg].trousers = true;
    parts.erase(BodyPart::kRightLeg);
  }
  for (auto& [part, g] : parts) {
    const PartPanels panels = measure_part(part, g, pattern, gm, fp);
    fit_part(part, g, panels, parts, pattern, body, options);
    widen_cylinder(g.cyl, options.clearance_m, options.girth_allowance, panels.width);
  }
  if (trousers) parts[BodyPart::kRightLeg] = parts[BodyPart::kLeftLeg];
  return parts;
}

// Where each panel's material coordinates go in the flat layout of the garment's pattern
// coordinates (side by side, as the panels are).
std::vector<Vec2> material_layout(const GarmentMesh& gm) {
  GarmentMesh in_material;
  for (const GarmentPanelMesh& pm : gm.panels) {
    GarmentPanelMesh flat;
    flat.vertices_m = material_coordinates(pm);
    in_material.panels.push_back(std::move(flat));
  }
  return flat_layout_offsets(in_material);
}

// How panel p faces its part: the file's directions turned onto the body's axis, an override's
// angle and shift.
PanelFrame panel_frame(int p, const FilePanel& f, const PartGeometry& g, const Pattern& pattern,
                       const PlacementOptions& options) {
  PanelFrame fr;
  const Vec3 n = f.outward;
  fr.ap = (g.file_axis - g.file_axis.dot(n) * n).normalized();
  fr.tau = fr.ap.cross(n);
  const Eigen::Quaterniond Q = Eigen::Quaterniond::FromTwoVectors(g.file_axis, g.cyl.axis);
  fr.phi_n = g.cyl.phi_of_direction(Q * n);
  fr.shift = g.shift;
  auto o = options.overrides.find(pattern.panels[p].name);
  if (o != options.overrides.end()) {
    if (o->second.angle_deg) fr.phi_n = *o->second.angle_deg * kPi / 180.0;
    fr.shift += o->second.shift_m;
  }
  return fr;
}

// How far across its part (along tau, from the part's middle) the panel's centroid goes: as
// the file has it or, for trousers, so that the panel's edge nearest the middle lies kSideGap_m / 2
// from it (pattern files draw trouser panels spread apart, each leg's about that leg).
double across_offset(const GarmentPanelMesh& pm, const FilePanel& f, const PartGeometry& g, const PanelFrame& fr) {
  const double offset = (f.centroid - g.file_origin).dot(fr.tau);
  if (!g.trousers) return offset;
  double s_lo = 1e30, s_hi = -1e30;
  for (const Vec2& v : pm.vertices_m) {
    const double s = (file_point(f, v) - f.centroid).dot(fr.tau);
    s_lo = std::min(s_lo, s);
    s_hi = std::max(s_hi, s);
  }
  return offset < 0 ? -0.5 * kSideGap_m - s_hi : 0.5 * kSideGap_m - s_lo;
}

// The panel's extent around the girth (as a fraction of it) and along the axis, on layer 0.
Extent panel_extent(const GarmentPanelMesh& pm, const FilePanel& f, const PartGeometry& g, const PanelFrame& fr) {
  double s_lo = 1e30, s_hi = -1e30, h_lo = 1e30, h_hi = -1e30;
  for (const Vec2& v : pm.vertices_m) {
    const Vec3 x = file_point(f, v);
    s_lo = std::min(s_lo, (x - f.centroid).dot(fr.tau));
    s_hi = std::max(s_hi, (x - f.centroid).dot(fr.tau));
    h_lo = std::min(h_lo, (x - f.centroid).dot(fr.ap));
    h_hi = std::max(h_hi, (x - f.centroid).dot(fr.ap));
  }
  const double centre_fraction = (g.cyl.arc_at(fr.phi_n) + across_offset(pm, f, g, fr)) / g.cyl.girth();
  return Extent{f.part, centre_fraction + s_lo / g.cyl.girth(), centre_fraction + s_hi / g.cyl.girth(),
                f.centroid.dot(g.file_axis) + h_lo, f.centroid.dot(g.file_axis) + h_hi, 0};
}

// Whether two panels are of one part and overlap along its axis by over a centimetre.
bool beside(const Extent& o, const Extent& e) {
  return o.part == e.part && std::min(o.h_hi, e.h_hi) - std::max(o.h_lo, e.h_lo) > 0.01;
}

// The panel's layer: one for each overlap around the girth with a panel placed before it
// beside it (none on a skirt's cone, whose panels lie side by side, or for a hood laid flat).
int panel_layer(const Extent& e, const std::vector<Extent>& placed, const PartGeometry& g) {
  int layer = 0;
  for (const Extent& o : placed) {
    if (!beside(o, e) || g.cone || g.file_offset) continue;  // a skirt's panels lie side by side on its cone
    for (double wrap : {-1.0, 0.0, 1.0})
      if (std::min(o.s_hi + wrap, e.s_hi) - std::max(o.s_lo + wrap, e.s_lo) > 0.01 / g.cyl.girth()) ++layer;
  }
  return layer;
}

// How far around the girth, as a fraction of it, the panel moves away from the panels of its
// layer it meets edge on edge (kSideGap_m); counts each move in `moved`.
double nudge_apart(const Extent& e, const std::vector<Extent>& placed, const PartGeometry& g, int& moved) {
  double nudge = 0;
  const double side_gap = kSideGap_m / g.cyl.girth();
  for (const Extent& o : placed) {
    if (!beside(o, e) || o.layer != e.layer || g.cone || g.file_offset) continue;
    for (double wrap : {-1.0, 0.0, 1.0}) {
      const double overlap = std::min(o.s_hi + wrap, e.s_hi + nudge) - std::max(o.s_lo + wrap, e.s_lo + nudge);
      if (overlap <= -side_gap || overlap > 0.01 / g.cyl.girth()) continue;
      const bool after = e.s_lo + e.s_hi + 2 * nudge > o.s_lo + o.s_hi + 2 * wrap;
      nudge += (after ? 1 : -1) * (overlap + side_gap);
      ++moved;
    }
  }
  return nudge;
}

// The cylinder of a part's layer: the part's, kLayer_m further out per layer, made on first use.
Cylinder& layer_cylinder(std::map<std::pair<BodyPart, int>, Cylinder>& layers, BodyPart part, int layer,
                         const Cylinder& cyl) {
  auto [lit, fresh] = layers.try_emplace({part, layer}, cyl);
  Cylinder& c = lit->second;
  if (fresh && layer > 0) {
    c.r1 += layer * kLayer_m;
    c.r2 += layer * kLayer_m;
    c.tabulate();
  }
  return c;
}

// Rolls panel p onto cylinder c (its middle at arc length s_centre), onto its part's cone or,
// for a hood, lays it where the file puts it moved by the part's offset; writes its vertices'
// positions and pattern coordinates (mirrored where the file's loop is clockwise, placed at
// `offset` in the layout), its triangles and its part.
void roll_panel(PlacedGarment& out, int p, const Pattern& pattern, const GarmentPanelMesh& pm, const FilePanel& f,
                const PartGeometry& g, const PanelFrame& fr, const Cylinder& c, double s_centre, const Vec2& offset) {
  // On a skirt's cone: the panel's middle line on the ray of the development that faces
  // where the panel does, moved across by its offset in the file.
  // Each panel's top (along the panel) at the waist, lowered by an override's shift.
  double theta_c = 0, panel_top = -1e30;
  if (g.cone) {
    for (const Vec2& v : pm.vertices_m) panel_top = std::max(panel_top, (file_point(f, v) - f.centroid).dot(fr.ap));
    panel_top -= fr.shift - g.shift;
    theta_c = fr.phi_n * g.cone->sin_a() + across_offset(pm, f, g, fr) / (g.cone->rho_top() + panel_top);
  }
  const bool mirror = pattern.panels[p].clockwise;
  const int first = out.panel_first_vertex[p];
  const std::vector<Vec2> material = material_coordinates(pm);
  for (size_t v = 0; v < pm.vertices_m.size(); ++v) {
    const Vec3 x = file_point(f, pm.vertices_m[v]);
    const double s = (x - f.centroid).dot(fr.tau), h = (x - f.centroid).dot(fr.ap) + f.centroid.dot(g.file_axis);
    out.mesh.positions.row(first + v) =
        (g.file_offset ? Vec3(x + *g.file_offset)
         : g.cone      ? g.cone->roll(theta_c, s, panel_top - (x - f.centroid).dot(fr.ap))
                       : c.point(h + fr.shift, c.phi_at(s_centre + s)))
            .transpose();
    Vec2 u = material[v];
    if (mirror) u.x() = -u.x();
    out.mesh.pattern[first + v] = u + offset;
  }
  for (const auto& t : pm.triangles) {
    std::array<int, 3> tri{first + t[0], first + t[1], first + t[2]};
    if (mirror) std::swap(tri[1], tri[2]);
    out.mesh.triangles.push_back(tri);
    out.panel_of_triangle.push_back(p);
  }
  out.panel_part.push_back(f.part);
}

// Mirrored panels were laid out unmirrored: moves each back into its own layout box.
void unmirror_layout(PlacedGarment& out, const Pattern& pattern, const GarmentMesh& gm, const std::vector<Vec2>& layout) {
  for (size_t p = 0; p < pattern.panels.size(); ++p) {
    if (!pattern.panels[p].clockwise) continue;
    double lo = 1e30, hi = -1e30, lo0 = 1e30;
    for (int v = out.panel_first_vertex[p]; v < out.panel_first_vertex[p + 1]; ++v) {
      lo = std::min(lo, out.mesh.pattern[v].x());
      hi = std::max(hi, out.mesh.pattern[v].x());
    }
    for (const Vec2& v : material_coordinates(gm.panels[p])) lo0 = std::min(lo0, v.x());
    (void)hi;
    for (int v = out.panel_first_vertex[p]; v < out.panel_first_vertex[p + 1]; ++v)
      out.mesh.pattern[v].x() += (lo0 + layout[p].x()) - lo;
  }
}

// Seams: the stitches' vertex pairs, each pair once, with their stitches.
void add_seam_pairs(PlacedGarment& out, const GarmentMesh& gm) {
  std::vector<std::array<int, 2>> pairs;
  for (size_t s = 0; s < gm.stitches.size(); ++s) {
    const StitchVertexPairs& st = gm.stitches[s];
    for (const auto& pr : st.pairs) {
      std::array<int, 2> q{out.panel_first_vertex[st.panel_a] + pr[0], out.panel_first_vertex[st.panel_b] + pr[1]};
      if (q[0] == q[1]) continue;
      if (q[0] > q[1]) std::swap(q[0], q[1]);
      if (std::find(pairs.begin(), pairs.end(), q) != pairs.end()) continue;
      pairs.push_back(q);
      out.seam_stitch.push_back(static_cast<int>(s));
    }
  }
  out.seam_pairs = std::move(pairs);
}

// Vertices that ended nearer the body than half the clearance move out along its normal.
void push_out_of_body(PlacedGarment& out, const BindBody& body, double clearance) {
  ColliderSpec spec;
  spec.shape = ColliderShape::kMesh;
  spec.name = "body";
  const Points body_positions = body.positions;
  auto collider = make_mesh_collider(
      spec, body.triangles, [body_positions](double, Points& out_positions) { out_positions = body_positions; }, true);
  collider->prepare(0, 0);
  const double keep = 0.5 * clearance;
  for (int v = 0; v < out.mesh.num_vertices(); ++v) {
    SurfacePoint sp;
    const Vec3 x = out.mesh.positions.row(v).transpose();
    if (!collider->closest(x, keep, true, v, sp) || sp.distance >= keep) continue;
    out.mesh.positions.row(v) = (sp.point + keep * sp.normal).transpose();
    ++out.vertices_pushed_out;
  }
}

}  // namespace

PlacedGarment place_garment(const Pattern& pattern, const GarmentMesh& gm, const BindBody& body,
                            const PlacementOptions& options) {
  check_overrides(pattern, options);
  const std::vector<FilePanel> fp = file_panels(pattern, gm, options);
  // Trousers go on the body with its legs apart, so that their inseams close between the legs.
  bool left_leg = false, right_leg = false;
  for (const FilePanel& f : fp) {
    left_leg = left_leg || f.part == BodyPart::kLeftLeg;
    right_leg = right_leg || f.part == BodyPart::kRightLeg;
  }
  const bool legs_apart = left_leg && right_leg && body.legs_apart_positions.rows() == body.positions.rows();
  BindBody apart;
  if (legs_apart) {
    apart.positions = body.legs_apart_positions;
    apart.triangles = body.triangles;
    apart.rig = body.legs_apart_rig;
    apart.spec = body.spec;
  }
  const BindBody& on = legs_apart ? apart : body;
  std::map<BodyPart, PartGeometry> parts = part_geometries(pattern, gm, on, fp, options);

  // The mesh's pattern coordinates are material coordinates (turned by each panel's grain),
  // laid out side by side as they are.
  PlacedGarment out;
  const std::vector<Vec2> layout = material_layout(gm);
  const int np = static_cast<int>(pattern.panels.size());
  out.panel_first_vertex.push_back(0);
  int total = 0;
  for (int p = 0; p < np; ++p) out.panel_first_vertex.push_back(total += static_cast<int>(gm.panels[p].vertices_m.size()));
  out.mesh.positions.resize(total, 3);
  out.mesh.pattern.resize(total);

  // Roll each panel onto its part's cylinder, on a layer of its own where it would lie on a
  // panel placed before it, moved apart from one it meets edge on edge.
  std::vector<Extent> placed_extents;
  std::map<std::pair<BodyPart, int>, Cylinder> layers;
  for (int p = 0; p < np; ++p) {
    const FilePanel& f = fp[p];
    const PartGeometry& g = parts[f.part];
    const PanelFrame fr = panel_frame(p, f, g, pattern, options);
    Extent e = panel_extent(gm.panels[p], f, g, fr);
    e.layer = panel_layer(e, placed_extents, g);
    const double nudge = nudge_apart(e, placed_extents, g, out.panels_moved_apart);
    e.s_lo += nudge;
    e.s_hi += nudge;
    placed_extents.push_back(e);
    const Cylinder& c = layer_cylinder(layers, f.part, e.layer, g.cyl);
    const double s_centre = c.arc_at(fr.phi_n) + across_offset(gm.panels[p], f, g, fr) + nudge * c.girth();
    roll_panel(out, p, pattern, gm.panels[p], f, g, fr, c, s_centre, layout[p]);
  }
  unmirror_layout(out, pattern, gm, layout);
  add_seam_pairs(out, gm);
  push_out_of_body(out, on, options.clearance_m);
  out.legs_apart = legs_apart;
  return out;
}

}  // namespace weft
