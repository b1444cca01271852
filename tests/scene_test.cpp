// The scene format: the documented example loads, and every error path names where it is.
#include "polyrad/scene/scene.h"

#include <gtest/gtest.h>

#include "test_support.h"

namespace polyrad {
namespace {

TEST(Scene, TheDocumentedExampleLoads) {
  Scene s = load_scene(std::string(POLYRAD_TEST_DATA_DIR) + "/scene_format_example.json");
  EXPECT_EQ(s.objects.size(), 3u);
  EXPECT_EQ(s.materials.size(), 4u);
  EXPECT_EQ(s.objects[1].faces.size(), 5u);  // the short block's quads
  EXPECT_TRUE(s.objects[2].is_emitter);
  EXPECT_EQ(s.objects[2].patch_size, 20.0);
  EXPECT_EQ(s.objects[0].patch_size, 50.0);
  EXPECT_EQ(s.materials[s.objects[1].material].type, MaterialType::kMirror);
  EXPECT_DOUBLE_EQ(s.materials[2].roughness, 0.15);
  EXPECT_EQ(s.find_object("light"), 2);
  EXPECT_EQ(s.find_object("nothing"), -1);
}

TEST(Scene, TheShippedScenesLoad) {
  for (const char* name : {"cornell-box", "cornell-mirror-cube", "cornell-glossy", "furnace"})
    EXPECT_NO_THROW(load_scene(test::scene_path(name))) << name;
}

const char* kValid = R"({
  "camera": {"position": [0, 1, -3], "look_at": [0, 1, 0], "fov_deg": 40, "width": 16, "height": 8},
  "patch_size": 0.5,
  "materials": {
    "white": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
  },
  "objects": [
    {"name": "floor", "material": "white",
     "polygon": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]},
    {"name": "lamp", "material": "white", "emission": [1, 1, 1],
     "polygon": [[-0.2, 2, -0.2], [0.2, 2, -0.2], [0.2, 2, 0.2], [-0.2, 2, 0.2]]}
  ]
})";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// Loads text (with optional extra files) and expects an InputError mentioning `words`,
// at `line` when given.
void expect_error(const std::string& text, const std::string& words, int line = 0,
                  const std::vector<std::pair<std::string, std::string>>& files = {}) {
  auto dir = test::temp_dir();
  for (const auto& [name, body] : files) test::write_file(dir, name, body);
  try {
    test::scene_from_json(text, dir);
    ADD_FAILURE() << "no error; expected: " << words;
  } catch (const InputError& e) {
    std::string what = e.what();
    EXPECT_NE(what.find(words), std::string::npos) << "message: " << what;
    EXPECT_FALSE(e.where().file.empty()) << what;
    if (line > 0) {
      EXPECT_EQ(e.where().line, line) << what;
    }
  }
}

TEST(Scene, ValidBaseLoads) { EXPECT_NO_THROW(test::scene_from_json(kValid)); }

TEST(Scene, SyntaxError) {
  expect_error(replaced(kValid, "\"patch_size\": 0.5,", "\"patch_size\": 0.5"), "expected ','", 4);
}
TEST(Scene, UnknownTopLevelKey) {
  expect_error(replaced(kValid, "\"patch_size\"", "\"patchsize\": 1, \"patch_size\""),
               "unknown or unused key 'patchsize'", 3);
}
TEST(Scene, MissingCamera) {
  expect_error(replaced(kValid, "\"camera\"", "\"camara\""), "needs the key 'camera'");
}
TEST(Scene, MissingPatchSize) {
  expect_error(replaced(kValid, "\"patch_size\": 0.5,", ""), "needs the key 'patch_size'");
}
TEST(Scene, PatchSizeWrongKind) {
  expect_error(replaced(kValid, "\"patch_size\": 0.5", "\"patch_size\": \"big\""),
               "must be a number", 3);
}
TEST(Scene, PatchSizeNotPositive) {
  expect_error(replaced(kValid, "\"patch_size\": 0.5", "\"patch_size\": 0"), "must be > 0", 3);
}
TEST(Scene, CameraUnknownKey) {
  expect_error(replaced(kValid, "\"fov_deg\"", "\"zoom\": 2, \"fov_deg\""),
               "unknown or unused key 'zoom' in camera", 2);
}
TEST(Scene, CameraBadFov) {
  expect_error(replaced(kValid, "\"fov_deg\": 40", "\"fov_deg\": 180"), "fov_deg", 2);
}
TEST(Scene, CameraWidthNotInteger) {
  expect_error(replaced(kValid, "\"width\": 16", "\"width\": 16.5"), "integer", 2);
}
TEST(Scene, CameraLooksAtItself) {
  expect_error(replaced(kValid, "\"look_at\": [0, 1, 0]", "\"look_at\": [0, 1, -3]"),
               "equals its position");
}
TEST(Scene, CameraUpAlongView) {
  expect_error(replaced(kValid, "\"fov_deg\"", "\"up\": [0, 0, 1], \"fov_deg\""), "parallel");
}
TEST(Scene, CameraVectorLength) {
  expect_error(replaced(kValid, "[0, 1, -3]", "[0, 1]"), "array of 3 numbers", 2);
}
TEST(Scene, MaterialUnknownType) {
  expect_error(replaced(kValid, "\"type\": \"diffuse\"", "\"type\": \"velvet\""),
               "unknown type 'velvet'", 5);
}
TEST(Scene, MaterialUnusedValue) {
  expect_error(
      replaced(kValid, "\"type\": \"diffuse\",", "\"type\": \"diffuse\", \"roughness\": 0.1,"),
      "unknown or unused key 'roughness'", 5);
}
TEST(Scene, MaterialReflectanceRange) {
  expect_error(replaced(kValid, "[0.5, 0.5, 0.5]", "[0.5, 1.5, 0.5]"), "must lie in [0, 1", 5);
}
TEST(Scene, MaterialAlbedoAboveOne) {
  expect_error(replaced(kValid, R"("white": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]})",
                        R"("white": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "hot": {"type": "glossy", "diffuse": [0.5, 0.5, 0.5], "specular": [0.6, 0.2, 0.2], "roughness": 0.2})"),
               "albedo could exceed 1", 6);
}
TEST(Scene, MaterialUnsafeAlbedoAllowedBehindTheFlag) {
  std::string text = replaced(kValid, "[0.5, 0.5, 0.5]", "[1.2, 1.2, 1.2]");
  SceneOptions unsafe;
  unsafe.allow_unsafe_albedo = true;
  auto dir = test::temp_dir();
  EXPECT_NO_THROW(load_scene(test::write_file(dir, "s.json", text), unsafe));
  expect_error(text, "must lie in [0, 1");
}
TEST(Scene, MaterialRoughnessRange) {
  expect_error(replaced(kValid, R"({"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]})",
                        R"({"type": "glossy", "specular": [0.5, 0.5, 0.5], "roughness": -0.1})"),
               "roughness", 5);
}
TEST(Scene, MaterialPhongNeedsExponent) {
  expect_error(replaced(kValid, R"({"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]})",
                        R"({"type": "phong", "specular": [0.5, 0.5, 0.5]})"),
               "needs the key 'exponent'", 5);
}
TEST(Scene, ObjectWithoutName) {
  expect_error(replaced(kValid, "\"name\": \"floor\", ", ""), "needs the key 'name'", 8);
}
TEST(Scene, ObjectNameTwice) {
  expect_error(replaced(kValid, "\"name\": \"lamp\"", "\"name\": \"floor\""), "used twice", 10);
}
TEST(Scene, ObjectUnknownMaterial) {
  expect_error(replaced(kValid, "\"material\": \"white\",\n     \"polygon\"",
                        "\"material\": \"whte\",\n     \"polygon\""),
               "unknown material 'whte'", 8);
}
TEST(Scene, ObjectUnknownKey) {
  expect_error(replaced(kValid, "\"name\": \"floor\",", "\"name\": \"floor\", \"colour\": 1,"),
               "unknown or unused key 'colour'", 8);
}
TEST(Scene, ObjectPolygonAndMesh) {
  expect_error(
      replaced(kValid, "\"name\": \"floor\",", "\"name\": \"floor\", \"mesh\": \"a.obj\","),
      "exactly one of 'polygon' and 'mesh'", 8);
}
TEST(Scene, ObjectTooFewPoints) {
  expect_error(replaced(kValid, "[[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]",
                        "[[-1, 0, -1], [-1, 0, 1]]"),
               "at least 3 points", 9);
}
TEST(Scene, ObjectNotPlanar) {
  expect_error(replaced(kValid, "[1, 0, -1]]", "[1, 0.5, -1]]"), "not planar", 8);
}
TEST(Scene, ObjectNotConvex) {
  expect_error(replaced(kValid, "[[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]",
                        "[[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [-0.5, 0, 0.5]]"),
               "not convex", 8);
}
TEST(Scene, ObjectDegenerate) {
  expect_error(replaced(kValid, "[[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]",
                        "[[0, 0, 0], [1, 0, 0], [2, 0, 0]]"),
               "degenerate", 8);
}
TEST(Scene, ObjectNegativeEmission) {
  expect_error(replaced(kValid, "[1, 1, 1]", "[1, -1, 1]"), "must not be negative", 10);
}
TEST(Scene, ObjectPatchSize) {
  expect_error(replaced(kValid, "\"name\": \"lamp\",", "\"name\": \"lamp\", \"patch_size\": -2,"),
               "must be > 0", 10);
}
TEST(Scene, NoObjects) {
  expect_error(replaced(kValid, R"("objects": [)", R"("objects": [], "unused": [)"),
               "has no objects", 7);
}
TEST(Scene, MeshMissing) {
  expect_error(replaced(kValid, "\"polygon\": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]",
                        "\"mesh\": \"nowhere.obj\""),
               "does not exist", 9);
}

const std::string kMeshObject = "\"mesh\": \"m.obj\"";
std::string with_mesh() {
  return replaced(kValid, "\"polygon\": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]",
                  kMeshObject);
}

TEST(Scene, MeshLoads) {
  auto dir = test::temp_dir();
  test::write_file(dir, "m.obj",
                   "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvn 0 1 0\nf 1//1 4//1 3//1 2//1\n");
  Scene s = test::scene_from_json(with_mesh(), dir);
  ASSERT_EQ(s.objects[0].faces.size(), 1u);
  EXPECT_EQ(s.objects[0].faces[0].vertices.size(), 4u);
}
TEST(Scene, MeshUnknownStatement) {
  expect_error(with_mesh(), "unsupported statement 'curv'", 2, {{"m.obj", "v 0 0 0\ncurv 1 2\n"}});
}
TEST(Scene, MeshIndexOutOfRange) {
  expect_error(with_mesh(), "does not exist", 4,
               {{"m.obj", "v 0 0 0\nv 1 0 0\nv 1 0 1\nf 1 2 9\n"}});
}
TEST(Scene, MeshBadNumber) {
  expect_error(with_mesh(), "three numbers", 1, {{"m.obj", "v 0 zero 0\n"}});
}
TEST(Scene, MeshNoFaces) { expect_error(with_mesh(), "has no faces", 0, {{"m.obj", "v 0 0 0\n"}}); }
TEST(Scene, MeshDegenerateFace) {
  expect_error(with_mesh(), "degenerate", 4, {{"m.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"}});
}

TEST(Scene, HashFollowsTheMeshes) {
  auto dir = test::temp_dir();
  test::write_file(dir, "m.obj", "v 0 0 0\nv 1 0 0\nv 1 0 1\nf 1 3 2\n");
  std::uint64_t a = test::scene_from_json(with_mesh(), dir).hash;
  test::write_file(dir, "m.obj", "v 0 0 0\nv 1 0 0\nv 1 0 2\nf 1 3 2\n");
  std::uint64_t b = test::scene_from_json(with_mesh(), dir).hash;
  EXPECT_NE(a, b);
}

}  // namespace
}  // namespace polyrad
