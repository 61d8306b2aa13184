#pragma once
// How a scene places a garment's panels on the body (docs/garments.md): the body parts a panel
// is wrapped around and a panel's placement chosen by hand. Placing them is garment/'s
// (weft/garment/placement.hpp).
#include <optional>
#include <string>

namespace weft {

/// The body parts panels are wrapped around.
enum class BodyPart { kTorso, kLeftArm, kRightArm, kLeftLeg, kRightLeg, kHead };
/// "torso", "left_arm", ...; throws InputError naming `where` for another name.
BodyPart parse_body_part(const std::string& name, const std::string& where);
std::string body_part_name(BodyPart part);

/// A panel's placement chosen by hand (the scene's `patterns.panels.NAME`).
struct PanelPlacementOverride {
  std::optional<BodyPart> part;
  /// Direction the panel's middle faces, in degrees about the part's axis: 0 = the front
  /// (+z), 90 = the wearer's left (+x) for the torso, legs and head; for an arm, 0 = the
  /// front and 90 = up.
  std::optional<double> angle_deg;
  double shift_m = 0;  ///< moves the panel along the part's axis (up the torso, out along an arm)
};

}  // namespace weft
