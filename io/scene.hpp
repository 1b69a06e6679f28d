// Scene files (DESIGN.md §7): JSON in, validated SimulationSettings and body descriptions
// (BodySpec, for the Bullet bridge) out.
//
// The loader is the boundary where user input enters Wake, so it checks everything:
// types, finiteness, ranges, unknown (misspelt) fields, duplicate keys, missing mesh
// files and whether the fluid fits in memory. Every problem is reported as one
// SceneError whose message is a single line "<file>: <field path>: <what is wrong>",
// e.g. "scene.json: fluid.blocks[0].max: must be greater than min on every axis ...".
// The field reference, with units, defaults and ranges, is io/SCENE_FORMAT.md.
#pragma once

#include "bullet_bridge/body_spec.hpp"
#include "coupling/simulation.hpp"

#include <stdexcept>
#include <string>
#include <vector>

namespace wake {

/// Bad input: a scene (or command-line value) that cannot be run. The message is one
/// line naming the file and the field.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A loaded scene: simulation settings plus what the runner needs.
struct SceneFile {
  std::string name;        ///< scene name, also the output file stem (<name>.h5)
  std::string path;        ///< the scene file as given by the user
  SimulationSettings sim;  ///< validated settings; fluid.speed_of_sound 0 means "auto";
                           ///< sim.bodies is left empty (the runner builds them from `bodies`)
  std::vector<BodySpec> bodies;  ///< validated bodies, in file order; mesh files absolute
  double end_time = 0;           ///< s, > 0: the run stops here (last output frame)
  double frame_rate = 30;        ///< 1/s, > 0: output frames per simulated second
  std::string text;              ///< the scene file's contents (JSON), as read
  double resolution = 1;         ///< the --resolution factor applied (1: none)
};

/// Reads and validates a scene file. Throws SceneError (one line, naming the field).
SceneFile loadScene(const std::string& path);

/// Same as loadScene, from JSON text; `path` names the file in messages and is the base
/// for relative paths inside the scene (mesh files).
SceneFile parseScene(const std::string& json_text, const std::string& path);

/// Replaces the scene's end time (command-line override). Throws SceneError naming
/// `option` when `end_time` is not a finite number > 0.
void overrideEndTime(SceneFile& scene, double end_time, const std::string& option = "--end");

/// Refines the scene: the fluid's particle radius is divided by `factor` (> 0), so the
/// particle count grows about factor^3. Automatic sizes (margins, tank walls) follow the
/// radius. Throws SceneError naming `option` when `factor` is not finite and > 0, or when
/// the refined fluid would not fit in memory.
void overrideResolution(SceneFile& scene, double factor,
                        const std::string& option = "--resolution");

/// Output frame times: 0, 1/frame_rate, 2/frame_rate, ... and end_time as the last one.
/// Returns the number of frames after frame 0 (so the run writes frameCount + 1 frames).
std::size_t frameCount(const SceneFile& scene);
/// Time of output frame k in [0, frameCount(scene)] (s); frame frameCount is end_time.
double frameTime(const SceneFile& scene, std::size_t k);

/// Estimated fluid particle count of the scene's blocks: per block, the product over the
/// axes of round(extent / spacing). Used to refuse scenes that cannot fit in memory.
double estimateFluidParticles(const SimulationSettings& sim);

}  // namespace wake
