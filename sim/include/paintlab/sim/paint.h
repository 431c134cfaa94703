#pragma once
// The sphere's paint in the simulator, from a paint file (brdf/paint.h): the model's BRDF
// and, when the file has [flakes], the part of the BRDF the flakes carry (the listed
// Cook-Torrance or AxF lobes, or the pearlescent glitter term) for the sparkle (flakes.h).
#include <filesystem>

#include "paintlab/brdf/paint.h"
#include "paintlab/sim/world.h"

namespace paintlab::sim {

// Throws DataError for a spec the simulator cannot sparkle (flakes on a MERL table).
SimPaint sim_paint(const brdf::PaintSpec& spec);
// load_paint_file + sim_paint (ConfigError/IoError from the paint file).
SimPaint load_sim_paint(const std::filesystem::path& paint_file);
// A grey Lambertian paint of albedo rho: the white reference sphere of the scale calibration.
SimPaint reference_paint(double albedo);
// The glossy black calibration sphere of the sphere and light calibrations: diffuse 0.01,
// one Beckmann lobe of ks 0.6, m 0.03, Fresnel r 0.05.
SimPaint glossy_black_sphere_paint();

}  // namespace paintlab::sim
