#include "app/io/dataset_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>
#include <matio.h>

#include "app/io/image_io.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

std::runtime_error DatasetError(const fs::path& file, const std::string& what) {
  return std::runtime_error(file.string() + ": " + what);
}

// Non-empty, non-comment lines of a text file, with their line numbers.
std::vector<std::pair<int, std::string>> ReadLines(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw DatasetError(path, "cannot be opened");
  std::vector<std::pair<int, std::string>> lines;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t,");
    if (first == std::string::npos || line[first] == '#') continue;
    lines.emplace_back(number, line);
  }
  return lines;
}

// Every line holds exactly `columns` finite numbers (spaces, tabs or commas between).
std::vector<std::vector<double>> ReadNumberRows(const fs::path& path, int columns) {
  std::vector<std::vector<double>> rows;
  for (const auto& [number, text] : ReadLines(path)) {
    std::string cleaned = text;
    std::replace(cleaned.begin(), cleaned.end(), ',', ' ');
    std::istringstream in(cleaned);
    std::vector<double> row;
    std::string token;
    while (in >> token) {
      size_t used = 0;
      double value = 0;
      try {
        value = std::stod(token, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != token.size() || !std::isfinite(value)) {
        throw DatasetError(path, "line " + std::to_string(number) + ": '" + token + "' is not a finite number");
      }
      row.push_back(value);
    }
    if (static_cast<int>(row.size()) != columns) {
      throw DatasetError(path, "line " + std::to_string(number) + " has " + std::to_string(row.size()) +
                                   " numbers; " + std::to_string(columns) + " required");
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

std::vector<Eigen::Vector3d> ReadVectors(const fs::path& path, size_t expected_count) {
  const auto rows = ReadNumberRows(path, 3);
  if (expected_count > 0 && rows.size() != expected_count) {
    throw DatasetError(path, std::to_string(rows.size()) + " lines for " + std::to_string(expected_count) +
                                 " images; one line per image required");
  }
  std::vector<Eigen::Vector3d> vectors;
  for (const auto& row : rows) vectors.emplace_back(row[0], row[1], row[2]);
  return vectors;
}

std::vector<std::string> ImageFileNames(const fs::path& folder) {
  const fs::path list = folder / "filenames.txt";
  std::vector<std::string> names;
  if (fs::exists(list)) {
    for (const auto& [number, text] : ReadLines(list)) {
      std::string name = text;
      name.erase(0, name.find_first_not_of(" \t"));
      name.erase(name.find_last_not_of(" \t") + 1);
      if (name.find('/') != std::string::npos || name == "..") {
        throw DatasetError(list, "line " + std::to_string(number) + ": '" + name +
                                     "' must be a file name in the dataset folder, not a path");
      }
      names.push_back(name);
    }
    if (names.empty()) throw DatasetError(list, "lists no image");
    return names;
  }
  // No list: the numbered images NN.png / NNN.png in name order.
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".png") continue;
    const std::string stem = entry.path().stem().string();
    if (!stem.empty() && std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      names.push_back(name);
    }
  }
  std::sort(names.begin(), names.end());
  if (names.empty()) throw DatasetError(folder, "has neither filenames.txt nor numbered .png images");
  return names;
}

ImageU8 ReadMask(const fs::path& path, int width, int height) {
  const ImageF stored = ReadImageFloat(path);
  if (!stored.SameSize(width, height)) {
    throw DatasetError(path, "is " + std::to_string(stored.width()) + "x" + std::to_string(stored.height()) +
                                 " but the images are " + std::to_string(width) + "x" + std::to_string(height));
  }
  ImageU8 mask(width, height, 1, 0);
  for (size_t i = 0; i < mask.num_pixels(); ++i) {
    float value = 0;
    for (int c = 0; c < std::min(3, stored.channels()); ++c) value = std::max(value, stored.data()[i * stored.channels() + c]);
    mask.data()[i] = value > 0.5f ? 1 : 0;
  }
  return mask;
}

// light_intensities.txt: one positive RGB triple per image.
std::vector<Eigen::Vector3d> ReadLightIntensities(const fs::path& folder, size_t num_lights) {
  const fs::path file = folder / "light_intensities.txt";
  if (!fs::exists(file)) throw DatasetError(file, "is missing");
  std::vector<Eigen::Vector3d> intensities = ReadVectors(file, num_lights);
  for (size_t k = 0; k < num_lights; ++k) {
    if ((intensities[k].array() <= 0).any()) {
      throw DatasetError(file, "light " + std::to_string(k + 1) + ": every intensity must be > 0");
    }
  }
  return intensities;
}

// One image as RGB (a grey file repeated in three channels), negatives clipped to 0.
ImageF ReadDatasetImage(const fs::path& file) {
  ImageF image = ReadImageFloat(file);
  if (image.channels() == 1) {
    ImageF rgb(image.width(), image.height(), 3);
    for (size_t i = 0; i < image.num_pixels(); ++i) {
      for (int c = 0; c < 3; ++c) rgb.data()[3 * i + c] = image.data()[i];
    }
    image = std::move(rgb);
  } else if (image.channels() != 3) {
    throw DatasetError(file, "has " + std::to_string(image.channels()) + " channels; 1 or 3 required");
  }
  for (size_t i = 0; i < image.size(); ++i) image.data()[i] = std::max(0.0f, image.data()[i]);
  return image;
}

// Every image, all of the first one's size; sets the dataset's size.
void ReadImages(PhotometricDataset* dataset) {
  for (size_t k = 0; k < dataset->image_files.size(); ++k) {
    const fs::path file = dataset->folder / dataset->image_files[k];
    ImageF image = ReadDatasetImage(file);
    if (k == 0) {
      dataset->width = image.width();
      dataset->height = image.height();
    } else if (!image.SameSize(dataset->width, dataset->height)) {
      throw DatasetError(file, "is " + std::to_string(image.width()) + "x" + std::to_string(image.height()) +
                                   " but " + dataset->image_files[0] + " is " + std::to_string(dataset->width) +
                                   "x" + std::to_string(dataset->height));
    }
    dataset->images.push_back(std::move(image));
  }
}

// light_directions.txt: one non-zero direction per light, normalised.
std::vector<Eigen::Vector3d> ReadLightDirections(const fs::path& folder, size_t num_lights) {
  const fs::path file = folder / "light_directions.txt";
  if (!fs::exists(file)) throw DatasetError(file, "is missing");
  std::vector<Eigen::Vector3d> directions = ReadVectors(file, num_lights);
  for (size_t k = 0; k < num_lights; ++k) {
    const double norm = directions[k].norm();
    if (!(norm > 1e-9)) throw DatasetError(file, "light " + std::to_string(k + 1) + " is a zero vector");
    directions[k] /= norm;
  }
  return directions;
}

// K.txt: the 3x3 camera matrix with positive focal lengths.
Eigen::Matrix3d ReadCameraMatrix(const fs::path& folder) {
  const fs::path file = folder / "K.txt";
  const auto rows = ReadNumberRows(file, 3);
  if (rows.size() != 3) throw DatasetError(file, "must hold 3 rows of 3 numbers (the camera matrix)");
  Eigen::Matrix3d camera_matrix;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera_matrix(r, c) = rows[r][c];
  }
  if (!(camera_matrix(0, 0) > 0 && camera_matrix(1, 1) > 0)) {
    throw DatasetError(file, "focal lengths K(0,0) and K(1,1) must be > 0");
  }
  return camera_matrix;
}

// mean_distance.txt, or without it a guess from the LEDs around the camera.
double ReadSurfaceDistance(const fs::path& folder, const std::vector<Eigen::Vector3d>& positions_in_cam) {
  const fs::path file = folder / "mean_distance.txt";
  double mean_z = 0;
  for (const Eigen::Vector3d& p : positions_in_cam) mean_z += p.z() / positions_in_cam.size();
  double distance_mm = mean_z;
  if (fs::exists(file)) {
    const auto rows = ReadNumberRows(file, 1);
    if (rows.size() != 1) throw DatasetError(file, "must hold one number (mm)");
    distance_mm = rows[0][0];
  } else {
    // LEDs sit around the camera; without a distance use the LEDs' spread as a scale.
    double spread = 0;
    for (const Eigen::Vector3d& p : positions_in_cam) spread = std::max(spread, p.head<2>().norm());
    distance_mm = std::max(mean_z, 0.0) + 2 * spread;
  }
  if (!(distance_mm > 0)) {
    throw DatasetError(file, "surface distance " + std::to_string(distance_mm) + " mm must be > 0");
  }
  return distance_mm;
}

// light_mu.txt: one falloff exponent >= 0 for all lights or one per light; 0 without the file.
std::vector<double> ReadLedMu(const fs::path& folder, size_t num_lights) {
  std::vector<double> mu_per_led(num_lights, 0.0);
  const fs::path file = folder / "light_mu.txt";
  if (!fs::exists(file)) return mu_per_led;
  const auto rows = ReadNumberRows(file, 1);
  if (rows.size() != 1 && rows.size() != num_lights) {
    throw DatasetError(file, std::to_string(rows.size()) + " values; 1 or one per light (" +
                                 std::to_string(num_lights) + ") required");
  }
  for (size_t k = 0; k < num_lights; ++k) {
    const double mu = rows.size() == 1 ? rows[0][0] : rows[k][0];
    if (!(mu >= 0)) throw DatasetError(file, "mu = " + std::to_string(mu) + " must be >= 0");
    mu_per_led[k] = mu;
  }
  return mu_per_led;
}

// The LUCES-style files: camera, LED positions and axes (converted from the
// OpenCV camera frame to the solver frame), surface distance, falloff.
void ReadNearFieldLights(PhotometricDataset* dataset) {
  const fs::path& folder = dataset->folder;
  const size_t num_lights = dataset->image_files.size();
  dataset->camera_matrix = ReadCameraMatrix(folder);
  const Eigen::Vector3d flip(1, -1, -1);  // OpenCV camera frame -> solver frame
  const auto positions_in_cam = ReadVectors(folder / "light_positions.txt", num_lights);
  for (const Eigen::Vector3d& p : positions_in_cam) dataset->light_positions_mm.push_back(p.cwiseProduct(flip));
  dataset->surface_distance_mm = ReadSurfaceDistance(folder, positions_in_cam);
  const fs::path directions_file = folder / "light_directions.txt";
  if (fs::exists(directions_file)) {
    for (const Eigen::Vector3d& axis : ReadVectors(directions_file, num_lights)) {
      if (!(axis.norm() > 1e-9)) throw DatasetError(directions_file, "an LED axis is a zero vector");
      dataset->led_axes.push_back(axis.cwiseProduct(flip).normalized());
    }
  } else {
    const Eigen::Vector3d centre(0, 0, -dataset->surface_distance_mm);
    for (const Eigen::Vector3d& p : dataset->light_positions_mm) dataset->led_axes.push_back((centre - p).normalized());
  }
  dataset->led_mu = ReadLedMu(folder, num_lights);
}

// Normal_gt.mat, of the images' size.
ImageF ReadNormalGroundTruth(const fs::path& file, int width, int height) {
  ImageF truth = ReadMatImage3(file, "Normal_gt");
  if (!truth.SameSize(width, height)) {
    throw DatasetError(file, "is " + std::to_string(truth.width()) + "x" + std::to_string(truth.height()) +
                                 " but the images are " + std::to_string(width) + "x" + std::to_string(height));
  }
  return truth;
}

struct MatCloser {
  void operator()(mat_t* mat) const { Mat_Close(mat); }
};
struct MatVarFreer {
  void operator()(matvar_t* var) const { Mat_VarFree(var); }
};

// The LEDs as point lights, their positions moved by `offset` (solver frame: 0).
std::vector<PointLight> PointLightsOf(const PhotometricDataset& dataset, const Eigen::Vector3d& offset) {
  std::vector<PointLight> lights;
  for (size_t k = 0; k < dataset.light_positions_mm.size(); ++k) {
    PointLight light;
    light.position = dataset.light_positions_mm[k] + offset;
    light.axis = dataset.led_axes[k];
    light.mu = dataset.led_mu[k];
    light.rgb_intensity = dataset.light_intensities[k];
    light.reference_distance = 1.0;
    lights.push_back(light);
  }
  return lights;
}

}  // namespace

ImageF ReadMatImage3(const fs::path& path, const std::string& variable) {
  std::unique_ptr<mat_t, MatCloser> mat(Mat_Open(path.string().c_str(), MAT_ACC_RDONLY));
  if (!mat) throw DatasetError(path, "is not a readable MAT file");
  std::unique_ptr<matvar_t, MatVarFreer> var(Mat_VarRead(mat.get(), variable.c_str()));
  if (!var) throw DatasetError(path, "has no variable '" + variable + "'");
  if (var->rank != 3 || var->dims[2] != 3) {
    std::ostringstream dims;
    for (int d = 0; d < var->rank; ++d) dims << (d ? "x" : "") << var->dims[d];
    throw DatasetError(path, "variable '" + variable + "' is " + dims.str() + "; height x width x 3 required");
  }
  if (var->isComplex || var->data == nullptr) {
    throw DatasetError(path, "variable '" + variable + "' must be a real numeric array");
  }
  const size_t height = var->dims[0], width = var->dims[1];
  const size_t count = height * width * 3;
  std::vector<double> values(count);
  switch (var->class_type) {
    case MAT_C_DOUBLE: {
      const double* data = static_cast<const double*>(var->data);
      std::copy(data, data + count, values.begin());
      break;
    }
    case MAT_C_SINGLE: {
      const float* data = static_cast<const float*>(var->data);
      std::copy(data, data + count, values.begin());
      break;
    }
    default:
      throw DatasetError(path, "variable '" + variable + "' must be double or single precision");
  }
  ImageF image(static_cast<int>(width), static_cast<int>(height), 3);
  for (size_t c = 0; c < 3; ++c) {
    for (size_t x = 0; x < width; ++x) {
      for (size_t y = 0; y < height; ++y) {
        const double value = values[y + height * (x + width * c)];
        image(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c)) =
            std::isfinite(value) ? static_cast<float>(value) : 0.0f;
      }
    }
  }
  return image;
}

void WriteMatImage(const fs::path& path, const std::string& variable, const ImageF& image) {
  const size_t height = image.height(), width = image.width(), channels = image.channels();
  std::vector<double> values(height * width * channels);
  for (size_t c = 0; c < channels; ++c) {
    for (size_t x = 0; x < width; ++x) {
      for (size_t y = 0; y < height; ++y) {
        values[y + height * (x + width * c)] = image(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c));
      }
    }
  }
  std::unique_ptr<mat_t, MatCloser> mat(Mat_CreateVer(path.string().c_str(), nullptr, MAT_FT_MAT5));
  if (!mat) throw DatasetError(path, "cannot be created");
  size_t dims[3] = {height, width, channels};
  std::unique_ptr<matvar_t, MatVarFreer> var(
      Mat_VarCreate(variable.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 3, dims, values.data(), MAT_F_DONT_COPY_DATA));
  if (!var || Mat_VarWrite(mat.get(), var.get(), MAT_COMPRESSION_ZLIB) != 0) {
    throw DatasetError(path, "writing variable '" + variable + "' failed");
  }
}

bool IsPhotometricDatasetFolder(const fs::path& folder) {
  return fs::is_directory(folder) && fs::exists(folder / "light_intensities.txt") &&
         (fs::exists(folder / "light_directions.txt") || fs::exists(folder / "light_positions.txt"));
}

PhotometricDataset LoadPhotometricDataset(const fs::path& folder, const DatasetLoadOptions& options) {
  if (!fs::is_directory(folder)) throw DatasetError(folder, "is not a folder");
  PhotometricDataset dataset;
  dataset.folder = folder;
  dataset.name = fs::absolute(folder).lexically_normal().filename().string();
  if (dataset.name.empty()) dataset.name = fs::absolute(folder).lexically_normal().parent_path().filename().string();
  const bool near_field = fs::exists(folder / "light_positions.txt");
  dataset.kind = near_field ? PhotometricDataset::Kind::kNearField : PhotometricDataset::Kind::kDistantLights;
  dataset.image_files = ImageFileNames(folder);
  const size_t num_lights = dataset.image_files.size();
  dataset.light_intensities = ReadLightIntensities(folder, num_lights);

  // The image size: from the first image (also when the images are not loaded).
  if (options.load_images) {
    ReadImages(&dataset);
  } else {
    const ImageF first = ReadImageFloat(folder / dataset.image_files[0]);
    dataset.width = first.width();
    dataset.height = first.height();
  }
  const fs::path mask_file = folder / "mask.png";
  dataset.mask = fs::exists(mask_file) ? ReadMask(mask_file, dataset.width, dataset.height)
                                       : ImageU8(dataset.width, dataset.height, 1, 1);

  if (near_field) {
    ReadNearFieldLights(&dataset);
  } else {
    dataset.light_directions = ReadLightDirections(folder, num_lights);
  }
  const fs::path truth_file = folder / "Normal_gt.mat";
  if (options.load_ground_truth && fs::exists(truth_file)) {
    dataset.normal_ground_truth = ReadNormalGroundTruth(truth_file, dataset.width, dataset.height);
  }
  return dataset;
}

std::unique_ptr<LightField> PhotometricDataset::MakeLightField() const {
  if (kind == Kind::kDistantLights) {
    return std::make_unique<DirectionalLightField>(width, height, light_directions, light_intensities);
  }
  // Surface points: each pixel's ray meets the plane at surface_distance_mm.
  const Eigen::Matrix3d inverse_k = camera_matrix.inverse();
  ImageF points(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d ray = inverse_k * Eigen::Vector3d(x, y, 1);
      const Eigen::Vector3d point_in_cam = ray * (surface_distance_mm / ray.z());
      points(x, y, 0) = static_cast<float>(point_in_cam.x());
      points(x, y, 1) = static_cast<float>(-point_in_cam.y());
      points(x, y, 2) = static_cast<float>(-point_in_cam.z());
    }
  }
  // The camera is the frame's origin: the view direction of the lobe fits.
  return std::make_unique<PointLightField>(PointLightsOf(*this, Eigen::Vector3d::Zero()), std::move(points),
                                           Eigen::Vector3d::Zero());
}

NearFieldTableFrame PhotometricDataset::TableFrame() const {
  if (kind != Kind::kNearField) {
    throw std::invalid_argument("PhotometricDataset " + name + ": distant lights have no near-field table frame");
  }
  const Eigen::Matrix3d& k = camera_matrix;
  if (k(0, 1) != 0 || k(1, 0) != 0 || k(2, 0) != 0 || k(2, 1) != 0 || k(2, 2) != 1) {
    std::ostringstream text;
    text << k.format(Eigen::IOFormat(Eigen::FullPrecision, Eigen::DontAlignCols, " ", "; "));
    throw std::invalid_argument((folder / "K.txt").string() + ": [" + text.str() +
                                "] has skew or a last row other than 0 0 1; the depth-aware light field needs a "
                                "pinhole K = [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  NearFieldTableFrame frame;
  CameraIntrinsics& intrinsics = frame.camera.intrinsics;
  intrinsics.width = width;
  intrinsics.height = height;
  intrinsics.fx = k(0, 0);
  intrinsics.fy = k(1, 1);
  intrinsics.cx = k(0, 2);
  intrinsics.cy = k(1, 2);
  // camera = flip * (table - (0, 0, d)): x right, y down, z forward from (0, 0, d).
  frame.camera.cam_from_table.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  frame.camera.cam_from_table.translation() = Eigen::Vector3d(0, 0, surface_distance_mm);
  frame.lights = PointLightsOf(*this, Eigen::Vector3d(0, 0, surface_distance_mm));
  return frame;
}

void PhotometricDataset::KeepLights(std::vector<int> indices) {
  std::sort(indices.begin(), indices.end());
  for (size_t k = 0; k < indices.size(); ++k) {
    if (indices[k] < 0 || indices[k] >= num_lights()) {
      throw std::invalid_argument("PhotometricDataset " + name + ": light index " + std::to_string(indices[k]) +
                                  " is not in [0, " + std::to_string(num_lights()) + ")");
    }
    if (k > 0 && indices[k] == indices[k - 1]) {
      throw std::invalid_argument("PhotometricDataset " + name + ": light index " + std::to_string(indices[k]) +
                                  " is given twice");
    }
  }
  const auto keep = [&](auto& table) {
    if (table.empty()) return;
    std::remove_reference_t<decltype(table)> kept;
    for (int i : indices) kept.push_back(std::move(table[i]));
    table = std::move(kept);
  };
  keep(image_files);
  keep(images);
  keep(light_intensities);
  keep(light_directions);
  keep(light_positions_mm);
  keep(led_axes);
  keep(led_mu);
}

std::vector<Eigen::Vector3d> PhotometricDataset::CentralLightDirections() const {
  if (kind == Kind::kDistantLights) return light_directions;
  const Eigen::Vector3d centre(0, 0, -surface_distance_mm);  // on the optical axis, camera at the origin
  std::vector<Eigen::Vector3d> dirs;
  for (const Eigen::Vector3d& p : light_positions_mm) dirs.push_back((p - centre).normalized());
  return dirs;
}

std::vector<const ImageF*> PhotometricDataset::ImagePointers() const {
  std::vector<const ImageF*> pointers;
  for (const ImageF& image : images) pointers.push_back(&image);
  return pointers;
}

}  // namespace scanbench
