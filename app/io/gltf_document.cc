#include "app/io/gltf_document.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/field_error.h"

namespace scanbench {
namespace {

// glTF's enumerations (the specification's accessor.componentType,
// bufferView.target and sampler tables).
constexpr int kFloat = 5126, kUnsignedShort = 5123;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kLinear = 9729, kLinearMipmapLinear = 9987, kClampToEdge = 33071;
constexpr int kTriangles = 4;

// The buffer and the accessors / buffer views that describe it.
class BufferBuilder {
 public:
  explicit BufferBuilder(std::vector<uint8_t>* buffer) : buffer_(*buffer) {}

  // A float attribute of `components` per vertex; POSITION needs its min and max.
  int AddFloats(const std::vector<float>& values, int components, const char* type, bool with_bounds = false) {
    const int view = AddView(values.data(), values.size() * sizeof(float), kArrayBuffer);
    nlohmann::json accessor = {
        {"bufferView", view}, {"componentType", kFloat}, {"count", values.size() / components}, {"type", type}};
    if (with_bounds) {
      std::vector<float> low(values.begin(), values.begin() + components), high = low;
      for (size_t i = 0; i < values.size(); ++i) {
        low[i % components] = std::min(low[i % components], values[i]);
        high[i % components] = std::max(high[i % components], values[i]);
      }
      accessor["min"] = low;
      accessor["max"] = high;
    }
    accessors_.push_back(accessor);
    return static_cast<int>(accessors_.size() - 1);
  }
  int AddIndices(const std::vector<uint16_t>& indices) {
    const int view = AddView(indices.data(), indices.size() * sizeof(uint16_t), kElementArrayBuffer);
    accessors_.push_back({{"bufferView", view}, {"componentType", kUnsignedShort}, {"count", indices.size()},
                          {"type", "SCALAR"}});
    // Keep the next view 4-byte aligned for its floats.
    while (buffer_.size() % 4 != 0) buffer_.push_back(0);
    return static_cast<int>(accessors_.size() - 1);
  }
  const nlohmann::json& accessors() const { return accessors_; }
  const nlohmann::json& views() const { return views_; }

 private:
  int AddView(const void* data, size_t bytes, int target) {
    const size_t offset = buffer_.size();
    buffer_.resize(offset + bytes);
    std::memcpy(buffer_.data() + offset, data, bytes);  // glTF is little-endian, as is x86/ARM
    views_.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}, {"target", target}});
    return static_cast<int>(views_.size() - 1);
  }
  std::vector<uint8_t>& buffer_;
  nlohmann::json accessors_ = nlohmann::json::array();
  nlohmann::json views_ = nlohmann::json::array();
};

// The box mean of `height` over the pixels within half a step of pixel (cx, cy).
double BoxMean(const ImageF& height, int cx, int cy, int step) {
  const int half = step / 2;
  double sum = 0;
  int count = 0;
  for (int yy = std::max(0, cy - half); yy <= std::min(height.height() - 1, cy + half); ++yy) {
    for (int xx = std::max(0, cx - half); xx <= std::min(height.width() - 1, cx + half); ++xx) {
      sum += height(xx, yy);
      ++count;
    }
  }
  return sum / count;
}

// The box mean at (x, y), interpolated bilinearly between the pixels around
// it: exact for a linear height, so the grid's slopes are the map's.
double BoxMeanAt(const ImageF& height, double x, double y, int step) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const int x1 = std::min(x0 + 1, height.width() - 1), y1 = std::min(y0 + 1, height.height() - 1);
  const double fx = x - x0, fy = y - y0;
  return (1 - fy) * ((1 - fx) * BoxMean(height, x0, y0, step) + fx * BoxMean(height, x1, y0, step)) +
         fy * ((1 - fx) * BoxMean(height, x0, y1, step) + fx * BoxMean(height, x1, y1, step));
}

struct DisplacedGrid {
  std::vector<float> positions, normals, uvs;
  std::vector<uint16_t> indices;
};

// Grid nodes at u = i / (nodes_x - 1), v = j / (nodes_y - 1) over the tile,
// shifted by `offset_x`; heights in metres along +Y; normals from central
// differences of the grid heights (one-sided at the border).
DisplacedGrid BuildDisplacedGrid(const GltfTileOptions& options, const ImageF& height, double offset_x) {
  const GltfGridSize size = DisplacedGridSize(height.width(), height.height(), options.displaced_max_vertices);
  const int nx = size.nodes_x, ny = size.nodes_y;
  std::vector<float> heights_m(static_cast<size_t>(nx) * ny);
  DisplacedGrid grid;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double u = double(i) / (nx - 1), v = double(j) / (ny - 1);
      const double px = std::clamp(u * height.width() - 0.5, 0.0, height.width() - 1.0);
      const double py = std::clamp(v * height.height() - 0.5, 0.0, height.height() - 1.0);
      const float h = static_cast<float>(BoxMeanAt(height, px, py, size.step_px) * options.height_unit_m);
      heights_m[static_cast<size_t>(j) * nx + i] = h;
      grid.positions.insert(grid.positions.end(), {static_cast<float>(offset_x + (u - 0.5) * options.width_m), h,
                                                   static_cast<float>((v - 0.5) * options.height_m)});
      grid.uvs.insert(grid.uvs.end(), {static_cast<float>(u), static_cast<float>(v)});
    }
  }
  const double dx = options.width_m / (nx - 1), dz = options.height_m / (ny - 1);
  const auto h = [&](int i, int j) { return double(heights_m[static_cast<size_t>(j) * nx + i]); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int i0 = std::max(0, i - 1), i1 = std::min(nx - 1, i + 1);
      const int j0 = std::max(0, j - 1), j1 = std::min(ny - 1, j + 1);
      const double slope_x = (h(i1, j) - h(i0, j)) / ((i1 - i0) * dx);
      const double slope_z = (h(i, j1) - h(i, j0)) / ((j1 - j0) * dz);
      const double norm = std::sqrt(slope_x * slope_x + 1 + slope_z * slope_z);
      grid.normals.insert(grid.normals.end(), {static_cast<float>(-slope_x / norm), static_cast<float>(1 / norm),
                                               static_cast<float>(-slope_z / norm)});
    }
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      // Top-left, bottom-left, bottom-right, top-right: counter-clockwise from +Y, as the tile.
      const auto a = static_cast<uint16_t>(j * nx + i), b = static_cast<uint16_t>((j + 1) * nx + i);
      const auto c = static_cast<uint16_t>((j + 1) * nx + i + 1), d = static_cast<uint16_t>(j * nx + i + 1);
      grid.indices.insert(grid.indices.end(), {a, b, c, a, c, d});
    }
  }
  return grid;
}

nlohmann::json Primitive(nlohmann::json attributes, int indices, int material) {
  return {{"attributes", std::move(attributes)}, {"indices", indices}, {"material", material}, {"mode", kTriangles}};
}

}  // namespace

void GltfTileOptions::Check() const {
  constexpr char kWhere[] = "GltfTileOptions";
  if (name.empty()) throw FieldError(kWhere, "name", "''", "must not be empty");
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "width_m", width_m, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "height_m", height_m, 0);
  for (const auto& [field, uri] : {std::pair{"basecolor_uri", &basecolor_uri}, std::pair{"normal_uri", &normal_uri},
                                   std::pair{"occlusion_roughness_metallic_uri", &occlusion_roughness_metallic_uri},
                                   std::pair{"buffer_uri", &buffer_uri}}) {
    if (uri->empty()) throw FieldError(kWhere, field, "''", "must name a file relative to the .gltf");
  }
  if (displaced_max_vertices < 4 || displaced_max_vertices > 65536) {
    throw FieldError(kWhere, "displaced_max_vertices", displaced_max_vertices, "must be in [4, 65536]");
  }
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "height_unit_m", height_unit_m, 0);
}

GltfGridSize DisplacedGridSize(int width, int height, int max_vertices) {
  GltfGridSize size;
  for (size.step_px = 1;; ++size.step_px) {
    size.nodes_x = std::max(2, (width - 1) / size.step_px + 1);
    size.nodes_y = std::max(2, (height - 1) / size.step_px + 1);
    if (static_cast<long long>(size.nodes_x) * size.nodes_y <= max_vertices || (size.nodes_x == 2 && size.nodes_y == 2)) {
      return size;
    }
  }
}

GltfTileFiles BuildGltfTile(const GltfTileOptions& options, const ImageF* height) {
  options.Check();
  if (height != nullptr && (height->channels() != 1 || height->width() < 2 || height->height() < 2)) {
    throw std::invalid_argument("glTF displaced mesh: the height map is " + std::to_string(height->width()) + "x" +
                                std::to_string(height->height()) + "x" + std::to_string(height->channels()) +
                                ", it must be one channel of at least 2x2");
  }
  const float x = static_cast<float>(options.width_m / 2), z = static_cast<float>(options.height_m / 2);
  GltfTileFiles files;
  BufferBuilder buffer(&files.buffer);
  // Corners: image top-left, bottom-left, bottom-right, top-right.
  const int position = buffer.AddFloats({-x, 0, -z, -x, 0, z, x, 0, z, x, 0, -z}, 3, "VEC3", true);
  const int normal = buffer.AddFloats({0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0}, 3, "VEC3");
  const int tangent = buffer.AddFloats({1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1}, 4, "VEC4");
  const int uv = buffer.AddFloats({0, 0, 0, 1, 1, 1, 1, 0}, 2, "VEC2");
  const int indices = buffer.AddIndices({0, 1, 2, 0, 2, 3});  // counter-clockwise seen from +Y

  nlohmann::json gltf;
  gltf["asset"] = {{"version", "2.0"}, {"generator", options.generator}};
  gltf["scene"] = 0;
  nlohmann::json nodes = {{{"name", options.name}, {"mesh", 0}}};
  nlohmann::json meshes = {
      {{"name", options.name},
       {"primitives",
        {Primitive({{"POSITION", position}, {"NORMAL", normal}, {"TANGENT", tangent}, {"TEXCOORD_0", uv}}, indices,
                   0)}}}};
  nlohmann::json materials = {{{"name", options.name},
                               {"pbrMetallicRoughness",
                                {{"baseColorTexture", {{"index", 0}}},
                                 {"metallicFactor", 0.0},  // a textile is a dielectric; the texture's B is 0 too
                                 {"roughnessFactor", 1.0},
                                 {"metallicRoughnessTexture", {{"index", 2}}}}},
                               {"normalTexture", {{"index", 1}, {"scale", 1.0}}},
                               {"occlusionTexture", {{"index", 2}, {"strength", 1.0}}}}};
  if (height != nullptr) {
    const std::string name = options.name + "_displaced";
    const DisplacedGrid grid = BuildDisplacedGrid(options, *height, 1.1 * options.width_m);
    const int grid_position = buffer.AddFloats(grid.positions, 3, "VEC3", true);
    const int grid_normal = buffer.AddFloats(grid.normals, 3, "VEC3");
    const int grid_uv = buffer.AddFloats(grid.uvs, 2, "VEC2");
    const int grid_indices = buffer.AddIndices(grid.indices);
    nodes.push_back({{"name", name}, {"mesh", 1}});
    meshes.push_back(
        {{"name", name},
         {"primitives",
          {Primitive({{"POSITION", grid_position}, {"NORMAL", grid_normal}, {"TEXCOORD_0", grid_uv}}, grid_indices, 1)}}});
    nlohmann::json displaced_material = materials[0];
    displaced_material["name"] = name;
    displaced_material.erase("normalTexture");
    materials.push_back(displaced_material);
  }
  nlohmann::json scene_nodes = nlohmann::json::array();
  for (size_t i = 0; i < nodes.size(); ++i) scene_nodes.push_back(i);
  gltf["scenes"] = {{{"name", options.name}, {"nodes", scene_nodes}}};
  gltf["nodes"] = nodes;
  gltf["meshes"] = meshes;
  // The maps cover one sample, not a repeating tile: clamp at the edges.
  gltf["samplers"] = {{{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear}, {"wrapS", kClampToEdge},
                       {"wrapT", kClampToEdge}}};
  gltf["images"] = {{{"uri", options.basecolor_uri}}, {{"uri", options.normal_uri}},
                    {{"uri", options.occlusion_roughness_metallic_uri}}};
  gltf["textures"] = {{{"sampler", 0}, {"source", 0}}, {{"sampler", 0}, {"source", 1}},
                      {{"sampler", 0}, {"source", 2}}};
  gltf["materials"] = materials;
  gltf["accessors"] = buffer.accessors();
  gltf["bufferViews"] = buffer.views();
  gltf["buffers"] = {{{"uri", options.buffer_uri}, {"byteLength", files.buffer.size()}}};
  files.json = gltf.dump(2) + "\n";
  return files;
}

}  // namespace scanbench
