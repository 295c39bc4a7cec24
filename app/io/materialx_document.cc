#include "app/io/materialx_document.h"

#include <array>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace {

constexpr char kWhere[] = "MaterialXMaterialOptions";

// MaterialX element names: letters, digits and '_', not starting with a digit.
std::string ElementName(const std::string& text) {
  std::string name;
  for (char c : text) name += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front()))) name = "m_" + name;
  return name;
}

const char* VectorType(int channels) { return channels == 4 ? "vector4" : channels == 3 ? "vector3" : "float"; }

// Writes the node graph's nodes, indented for a human reader.
class GraphWriter {
 public:
  explicit GraphWriter(std::ostringstream* out) : out_(*out) {}
  void Image(const std::string& name, const char* type, const std::string& file, const std::string& colorspace = "") {
    out_ << "    <image name=\"" << name << "\" type=\"" << type << "\">\n"
         << "      <input name=\"file\" type=\"filename\" value=\"" << XmlEscaped(file) << "\""
         << (colorspace.empty() ? "" : " colorspace=\"" + colorspace + "\"") << " />\n"
         << "    </image>\n";
  }
  // A node with inputs given as (name, type, "node:<nodename>" or a value).
  void Node(const std::string& category, const std::string& name, const char* type,
            std::initializer_list<std::array<std::string, 3>> inputs) {
    out_ << "    <" << category << " name=\"" << name << "\" type=\"" << type << "\">\n";
    for (const auto& [input, input_type, source] : inputs) {
      out_ << "      <input name=\"" << input << "\" type=\"" << input_type << "\" ";
      if (source.rfind("node:", 0) == 0) {
        out_ << "nodename=\"" << source.substr(5) << "\"";
      } else {
        out_ << "value=\"" << source << "\"";
      }
      out_ << " />\n";
    }
    out_ << "    </" << category << ">\n";
  }
  void Output(const std::string& name, const char* type, const std::string& node) {
    out_ << "    <output name=\"" << name << "\" type=\"" << type << "\" nodename=\"" << node << "\" />\n";
  }

 private:
  std::ostringstream& out_;
};

}  // namespace

void MaterialXMaterialOptions::Check() const {
  for (const auto& [field, file] : {std::pair{"basecolor_file", &basecolor_file}, std::pair{"normal_file", &normal_file},
                                    std::pair{"roughness_file", &roughness_file}, std::pair{"height_file", &height_file}}) {
    if (file->empty()) throw FieldError(kWhere, field, "''", "must name a file relative to the .mtlx");
  }
  if (basecolor_colorspace != "srgb_texture" && basecolor_colorspace != "lin_rec709" &&
      basecolor_colorspace != "acescg") {
    throw FieldError(kWhere, "basecolor_colorspace", basecolor_colorspace, "must be srgb_texture, lin_rec709 or acescg");
  }
  if (roughness_channels != 1 && roughness_channels != 3 && roughness_channels != 4) {
    throw FieldError(kWhere, "roughness_channels", roughness_channels, "must be 1, 3 or 4");
  }
  if (roughness_channel < 0 || roughness_channel >= roughness_channels) {
    throw FieldError(kWhere, "roughness_channel", roughness_channel, "must be in [0, roughness_channels - 1]");
  }
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "height_scale", height_scale, 0);
}

std::string MaterialXDocument(const MaterialXMaterialOptions& options) {
  options.Check();
  const std::string base = ElementName(options.name);
  const std::string graph = "NG_" + base;
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n"
      << "<materialx version=\"1.38\" colorspace=\"lin_rec709\">\n"
      << "  <!-- scanbench material " << XmlEscaped(options.name)
      << ": standard_surface (dielectric, metalness 0) with displacement from the height map. -->\n"
      << "  <nodegraph name=\"" << graph << "\">\n";
  GraphWriter nodes(&out);
  nodes.Image("basecolor_image", "color3", options.basecolor_file, options.basecolor_colorspace);
  nodes.Output("base_color_out", "color3", "basecolor_image");

  nodes.Image("normal_image", "vector3", options.normal_file);
  std::string normal_source = "normal_image";
  if (options.normal_y_down) {  // DirectX: g' = 1 - g, so that normalmap sees +Y up
    nodes.Node("multiply", "normal_flip_green", "vector3",
               {{"in1", "vector3", "node:normal_image"}, {"in2", "vector3", "1, -1, 1"}});
    nodes.Node("add", "normal_y_up", "vector3",
               {{"in1", "vector3", "node:normal_flip_green"}, {"in2", "vector3", "0, 1, 0"}});
    normal_source = "normal_y_up";
  }
  nodes.Node("normalmap", "normal_map", "vector3", {{"in", "vector3", "node:" + normal_source}});
  nodes.Output("normal_out", "vector3", "normal_map");

  std::string roughness_source = "roughness_image";
  nodes.Image("roughness_image", VectorType(options.roughness_channels), options.roughness_file);
  if (options.roughness_channels > 1) {
    nodes.Node("extract", "roughness_channel", "float",
               {{"in", VectorType(options.roughness_channels), "node:roughness_image"},
                {"index", "integer", std::to_string(options.roughness_channel)}});
    roughness_source = "roughness_channel";
  }
  if (options.roughness == MaterialXMaterialOptions::Roughness::kGgxAlpha) {
    nodes.Node("sqrt", "perceptual_roughness", "float", {{"in", "float", "node:" + roughness_source}});
    roughness_source = "perceptual_roughness";
  } else if (options.roughness == MaterialXMaterialOptions::Roughness::kSmoothness) {
    nodes.Node("subtract", "perceptual_roughness", "float",
               {{"in1", "float", "1"}, {"in2", "float", "node:" + roughness_source}});
    roughness_source = "perceptual_roughness";
  }
  nodes.Output("specular_roughness_out", "float", roughness_source);

  nodes.Image("height_image", "float", options.height_file);
  nodes.Output("height_out", "float", "height_image");
  out << "  </nodegraph>\n";

  std::ostringstream scale;
  scale << std::setprecision(9) << options.height_scale;
  out << "  <standard_surface name=\"SR_" << base << "\" type=\"surfaceshader\">\n"
      << "    <input name=\"base\" type=\"float\" value=\"1\" />\n"
      << "    <input name=\"base_color\" type=\"color3\" nodegraph=\"" << graph << "\" output=\"base_color_out\" />\n"
      << "    <input name=\"metalness\" type=\"float\" value=\"0\" />\n"
      << "    <input name=\"specular_roughness\" type=\"float\" nodegraph=\"" << graph
      << "\" output=\"specular_roughness_out\" />\n"
      << "    <input name=\"normal\" type=\"vector3\" nodegraph=\"" << graph << "\" output=\"normal_out\" />\n"
      << "  </standard_surface>\n"
      << "  <!-- Height in the file's unit times scale = scene units (metres, as glTF). -->\n"
      << "  <displacement name=\"DS_" << base << "\" type=\"displacementshader\">\n"
      << "    <input name=\"displacement\" type=\"float\" nodegraph=\"" << graph << "\" output=\"height_out\" />\n"
      << "    <input name=\"scale\" type=\"float\" value=\"" << scale.str() << "\" />\n"
      << "  </displacement>\n"
      << "  <surfacematerial name=\"M_" << base << "\" type=\"material\">\n"
      << "    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"SR_" << base << "\" />\n"
      << "    <input name=\"displacementshader\" type=\"displacementshader\" nodename=\"DS_" << base << "\" />\n"
      << "  </surfacematerial>\n"
      << "</materialx>\n";
  return out.str();
}

}  // namespace scanbench
