#pragma once
// A scene with contacts for tests that follow state across steps: the given cloth (the swing)
// let go of its pins and dropped onto a sphere and a floor, both with friction, so that
// contacts, friction and the contact flags carry state from step to step.
#include "weft/scene.hpp"

namespace weft::test {

inline Scene dropped_onto_sphere_and_floor(Scene scene) {
  scene.cloth.pin_vertices.clear();
  scene.cloth.pin_grid_nodes.clear();
  ColliderSpec sphere;
  sphere.shape = ColliderShape::kSphere;
  sphere.centre = Vec3(0.2, 0.5, -0.2);
  sphere.radius = 0.25;
  sphere.friction = 0.5;
  ColliderSpec floor;
  floor.shape = ColliderShape::kPlane;
  floor.point = Vec3(0, 0.3, 0);
  floor.friction = 0.8;
  scene.colliders = {sphere, floor};
  return scene;
}

}  // namespace weft::test
