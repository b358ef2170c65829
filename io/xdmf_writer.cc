#include "io/xdmf_writer.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "io/h5_handle.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

constexpr const char* kFix = h5::kWriteFix;

using h5::Checked;
using h5::Handle;
using h5::kMetadataBytes;
using h5::Quiet;
using h5::ReserveSpace;
using h5::Untimed;

// A matrix with one column per node or element is, in memory, the row-major
// (rows x components) array XDMF reads; a scalar field is stored 1-D.
void WriteDataset(hid_t parent, const std::string& name, hid_t type, const void* data, hsize_t rows,
                  hsize_t components, const std::string& where) {
  const hsize_t dims[2] = {rows, components};
  Handle space(Checked(H5Screate_simple(components == 1 ? 1 : 2, dims, nullptr),
                       "create a dataspace", where),
               H5Sclose);
  const Handle creation = Untimed(H5P_DATASET_CREATE, where);
  Handle set(Checked(H5Dcreate2(parent, name.c_str(), type, space.get(), H5P_DEFAULT, creation.get(),
                                H5P_DEFAULT),
                     "create dataset " + name, where),
             H5Dclose);
  Checked(H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "write dataset " + name,
          where);
}

void WriteRootAttribute(hid_t file, const char* name, int value, const std::string& where) {
  const bool exists =
      Checked(H5Aexists(file, name), std::string("look up attribute ") + name, where) > 0;
  Handle space(Checked(H5Screate(H5S_SCALAR), "create a dataspace", where), H5Sclose);
  Handle attribute(Checked(exists ? H5Aopen(file, name, H5P_DEFAULT)
                                  : H5Acreate2(file, name, H5T_NATIVE_INT, space.get(), H5P_DEFAULT,
                                               H5P_DEFAULT),
                           std::string("create attribute ") + name, where),
                   H5Aclose);
  Checked(H5Awrite(attribute.get(), H5T_NATIVE_INT, &value), std::string("write attribute ") + name,
          where);
}

// /time_s grows by one entry per step, so it is chunked and unlimited.
void CreateTimeDataset(hid_t file, const std::string& where) {
  const hsize_t dims[1] = {0}, max_dims[1] = {H5S_UNLIMITED}, chunk[1] = {256};
  Handle space(Checked(H5Screate_simple(1, dims, max_dims), "create a dataspace", where), H5Sclose);
  const Handle properties = Untimed(H5P_DATASET_CREATE, where);
  Checked(H5Pset_chunk(properties.get(), 1, chunk), "set chunking", where);
  Handle set(Checked(H5Dcreate2(file, "time_s", H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT,
                                properties.get(), H5P_DEFAULT),
                     "create dataset time_s", where),
             H5Dclose);
}

void AppendTime(hid_t file, hsize_t index, double t_s, const std::string& where) {
  Handle set(Checked(H5Dopen2(file, "time_s", H5P_DEFAULT), "open dataset time_s", where),
             H5Dclose);
  const hsize_t size[1] = {index + 1}, start[1] = {index}, count[1] = {1};
  Checked(H5Dset_extent(set.get(), size), "extend dataset time_s", where);
  Handle file_space(Checked(H5Dget_space(set.get()), "get a dataspace", where), H5Sclose);
  Checked(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
          "select in time_s", where);
  Handle memory_space(Checked(H5Screate_simple(1, count, nullptr), "create a dataspace", where),
                      H5Sclose);
  Checked(H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, memory_space.get(), file_space.get(), H5P_DEFAULT,
                   &t_s),
          "write time_s", where);
}

hid_t CreateGroup(hid_t parent, const std::string& name, const std::string& where) {
  const Handle creation = Untimed(H5P_GROUP_CREATE, where);
  return Checked(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, creation.get(), H5P_DEFAULT),
                 "create group " + name, where);
}

// Shortest text that reads back to the same double.
std::string Number(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string XmlEscape(const std::string& text) {
  std::string escaped;
  for (char c : text) {
    switch (c) {
      case '&':
        escaped += "&amp;";
        break;
      case '<':
        escaped += "&lt;";
        break;
      case '>':
        escaped += "&gt;";
        break;
      case '"':
        escaped += "&quot;";
        break;
      default:
        escaped += c;
    }
  }
  return escaped;
}

const char* AttributeType(Eigen::Index components) {
  switch (components) {
    case 1:
      return "Scalar";
    case 3:
      return "Vector";
    case 6:
      return "Tensor6";
    case 9:
      return "Tensor";
    default:
      return "Matrix";
  }
}

// One array of a step, as the .xmf describes it.
struct Attribute {
  std::string name;
  const char* center;  // "Node" or "Cell"
  std::string dataset;
  Eigen::Index rows, components;
};

const std::vector<Attribute> kNoAttributes;

struct Step {
  double t_s;
  std::vector<Attribute> attributes;
  std::string geometry;  // the step's own node positions; empty: the reference's
};

constexpr char kReferenceGeometry[] = "/mesh/geometry_m";

}  // namespace

struct XdmfTimeSeriesWriter::Impl {
  std::string h5_path, xmf_path;
  std::string h5_reference;  // the .h5's file name as the .xmf refers to it
  int num_nodes = 0, num_tets = 0;
  hid_t file = -1;
  bool closed = false;
  XdmfSeriesOptions options;
  Eigen::Matrix3Xd reference_m;  // kept for the deformed geometry
  std::vector<Step> steps;
  size_t listed = 0;  // steps the .xmf on disk lists

  bool XmfDue() const {
    const size_t unlisted = steps.size() - listed;
    return unlisted > 0 && (options.xmf_every_step || unlisted >= std::max<size_t>(1, steps.size() / 16));
  }

  void WriteGrid(std::ostream& xml, const std::string& indent, const std::string& name,
                 const Step* step) const;
  void WriteXmf();
  std::vector<Attribute> WriteStep(hid_t group, const std::string& prefix,
                                   const Eigen::Matrix3Xd& displacement_m,
                                   const MeshFields& fields) const;
};

void XdmfTimeSeriesWriter::Impl::WriteGrid(std::ostream& xml, const std::string& indent,
                                           const std::string& name, const Step* step) const {
  const auto item = [&](const std::string& dims, const char* type, int precision,
                        const std::string& dataset) {
    xml << indent << "    <DataItem Dimensions=\"" << dims << "\" NumberType=\"" << type
        << "\" Precision=\"" << precision << "\" Format=\"HDF\">" << h5_reference << ":" << dataset
        << "</DataItem>\n";
  };
  xml << indent << "<Grid Name=\"" << name << "\" GridType=\"Uniform\">\n";
  if (step) xml << indent << "  <Time Value=\"" << Number(step->t_s) << "\"/>\n";
  xml << indent << "  <Topology TopologyType=\"Tetrahedron\" NumberOfElements=\"" << num_tets
      << "\">\n";
  item(std::to_string(num_tets) + " 4", "Int", 4, "/mesh/topology");
  xml << indent << "  </Topology>\n" << indent << "  <Geometry GeometryType=\"XYZ\">\n";
  item(std::to_string(num_nodes) + " 3", "Float", 8,
       step && !step->geometry.empty() ? step->geometry : kReferenceGeometry);
  xml << indent << "  </Geometry>\n";
  // A bare mesh (no step yet) has no time and no attributes.
  for (const Attribute& attribute : step ? step->attributes : kNoAttributes) {
    xml << indent << "  <Attribute Name=\"" << attribute.name << "\" AttributeType=\""
        << AttributeType(attribute.components) << "\" Center=\"" << attribute.center << "\">\n";
    std::string dims = std::to_string(attribute.rows);
    // Appended, not `" " + std::to_string(...)`: GCC 12 warns falsely (-Wrestrict) on that.
    if (attribute.components > 1) (dims += ' ') += std::to_string(attribute.components);
    item(dims, "Float", 8, attribute.dataset);
    xml << indent << "  </Attribute>\n";
  }
  xml << indent << "</Grid>\n";
}

// Rewritten whole after each step and renamed into place, so a reader never
// sees a half-written description.
void XdmfTimeSeriesWriter::Impl::WriteXmf() {
  std::ostringstream xml;
  xml << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n";
  if (steps.empty()) {
    WriteGrid(xml, "    ", "mesh", nullptr);  // an empty temporal collection would not open
  } else {
    xml << "    <Grid Name=\"time_series\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (size_t k = 0; k < steps.size(); ++k) {
      WriteGrid(xml, "      ", "step_" + std::to_string(k), &steps[k]);
    }
    xml << "    </Grid>\n";
  }
  xml << "  </Domain>\n</Xdmf>\n";
  const std::string temporary = xmf_path + ".tmp";
  std::error_code error;
  {
    std::ofstream out(temporary);
    out << xml.str();
    out.close();
    if (!out) {
      const int reason = errno;  // the stream's last failed write, e.g. ENOSPC
      std::filesystem::remove(temporary, error);  // the previous description stays whole
      throw Error("cannot write the XDMF description: " + std::string(std::strerror(reason)), temporary,
                  h5::OutOfSpace(reason) ? h5::kSpaceFix : kFix);
    }
  }
  std::filesystem::rename(temporary, xmf_path, error);
  if (error) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw Error("cannot rename to the XDMF description: " + error.message(), xmf_path, kFix);
  }
  listed = steps.size();
}

std::vector<Attribute> XdmfTimeSeriesWriter::Impl::WriteStep(hid_t group, const std::string& prefix,
                                                             const Eigen::Matrix3Xd& displacement_m,
                                                             const MeshFields& fields) const {
  std::vector<Attribute> attributes;
  const auto write = [&](hid_t parent, const std::string& path, const std::string& name,
                         const char* center, const double* data, Eigen::Index rows,
                         Eigen::Index components) {
    WriteDataset(parent, name, H5T_NATIVE_DOUBLE, data, rows, components, h5_path);
    attributes.push_back({name, center, prefix + path + name, rows, components});
  };
  write(group, "/", kDisplacementName, "Node", displacement_m.data(), num_nodes, 3);
  struct Kind {
    const char* group;
    const char* center;
    const std::vector<std::pair<std::string, Eigen::MatrixXd>>* data;
  };
  for (const Kind& kind :
       {Kind{"point", "Node", &fields.point_data}, Kind{"cell", "Cell", &fields.cell_data}}) {
    if (kind.data->empty()) continue;
    Handle subgroup(CreateGroup(group, kind.group, h5_path), H5Gclose);
    for (const auto& [name, values] : *kind.data) {
      // Appended, not `"/" + std::string(...)`: GCC 12 warns falsely (-Wrestrict) on that.
      write(subgroup.get(), std::string("/").append(kind.group).append("/"), name, kind.center, values.data(),
            values.cols(), values.rows());
    }
  }
  return attributes;
}

XdmfTimeSeriesWriter::XdmfTimeSeriesWriter(const std::string& path, const sim::TetMesh& mesh,
                                           const XdmfSeriesOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& impl = *impl_;
  impl.options = options;
  impl.xmf_path = path + ".xmf";
  if (options.h5_file_name.empty()) {
    impl.h5_path = path + ".h5";
  } else if (std::filesystem::path(options.h5_file_name).has_parent_path() ||
             options.h5_file_name == std::filesystem::path(impl.xmf_path).filename()) {
    throw Error("the data file's name '" + options.h5_file_name + "' is a path or the description's own name",
                impl.xmf_path, "give a plain file name other than the .xmf's");
  } else {
    impl.h5_path = (std::filesystem::path(impl.xmf_path).parent_path() / options.h5_file_name).string();
  }
  if (options.deformed_geometry) impl.reference_m = mesh.X_m;
  impl.h5_reference = XmlEscape(std::filesystem::path(impl.h5_path).filename().string());
  impl.num_nodes = mesh.num_nodes();
  impl.num_tets = mesh.num_tets();
  Quiet();
  // Checked here so that the common mistake gets a plain message, not HDF5's error stack.
  const std::filesystem::path directory = std::filesystem::path(impl.h5_path).parent_path();
  if (!directory.empty() && !std::filesystem::is_directory(directory)) {
    throw Error("the output directory does not exist", impl.h5_path,
                "create it first, or choose another path");
  }
  impl.file = Checked(H5Fcreate(impl.h5_path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                      "create the file", impl.h5_path);
  try {
    const hsize_t mesh_bytes = impl.num_nodes * 3 * sizeof(double) + impl.num_tets * 4 * sizeof(int);
    ReserveSpace(impl.file, mesh_bytes + 4 * kMetadataBytes, impl.h5_path);
    WriteRootAttribute(impl.file, "complete", 0, impl.h5_path);
    Handle group(CreateGroup(impl.file, "mesh", impl.h5_path), H5Gclose);
    WriteDataset(group.get(), "geometry_m", H5T_NATIVE_DOUBLE, mesh.X_m.data(), impl.num_nodes, 3,
                 impl.h5_path);
    WriteDataset(group.get(), "topology", H5T_NATIVE_INT, mesh.tets.data(), impl.num_tets, 4,
                 impl.h5_path);
    Handle steps(CreateGroup(impl.file, "steps", impl.h5_path), H5Gclose);
    CreateTimeDataset(impl.file, impl.h5_path);
    Checked(H5Fflush(impl.file, H5F_SCOPE_GLOBAL), "flush the file", impl.h5_path);
    impl.WriteXmf();
  } catch (...) {
    H5Fclose(impl.file);
    throw;
  }
}

XdmfTimeSeriesWriter::~XdmfTimeSeriesWriter() {
  if (impl_->closed) return;
  Quiet();
  try {
    Close(false);
    Logger("io").warn("{} closed before the run finished: marked complete=0", impl_->h5_path);
  } catch (const std::exception& error) {
    Logger("io").error("closing {}: {}", impl_->h5_path, error.what());
  }
}

void XdmfTimeSeriesWriter::Append(double t_s, const Eigen::Matrix3Xd& displacement_m,
                                  const MeshFields& fields) {
  Impl& impl = *impl_;
  DG_CHECK(!impl.closed);
  const std::string step_name = "step " + std::to_string(impl.steps.size());
  if (!std::isfinite(t_s) || (!impl.steps.empty() && t_s <= impl.steps.back().t_s)) {
    throw Error("time " + Number(t_s) + " s is not finite or not after the previous step's",
                impl.h5_path + ", " + step_name, "append steps in increasing time");
  }
  if (displacement_m.cols() != impl.num_nodes) {
    throw Error("displacement has " + std::to_string(displacement_m.cols()) + " columns for " +
                    std::to_string(impl.num_nodes) + " nodes",
                impl.h5_path + ", " + step_name,
                "pass one displacement column per node of the mesh");
  }
  CheckMeshFields(fields, impl.num_nodes, impl.num_tets, impl.h5_path + ", " + step_name);
  char group_name[32];
  std::snprintf(group_name, sizeof(group_name), "/steps/%06zu", impl.steps.size());
  Step step{t_s, {}, {}};
  Quiet();
  hsize_t values = displacement_m.size();
  for (const auto& [name, data] : fields.point_data) values += data.size();
  for (const auto& [name, data] : fields.cell_data) values += data.size();
  if (impl.options.deformed_geometry) values += displacement_m.size();
  // The step's datasets, its groups and a new chunk of /time_s at most.
  const hsize_t metadata = (4 + fields.point_data.size() + fields.cell_data.size()) * kMetadataBytes;
  ReserveSpace(impl.file, values * sizeof(double) + metadata, impl.h5_path + ", " + step_name);
  {
    Handle group(CreateGroup(impl.file, group_name, impl.h5_path), H5Gclose);
    step.attributes = impl.WriteStep(group.get(), group_name, displacement_m, fields);
    if (impl.options.deformed_geometry) {
      const Eigen::Matrix3Xd deformed_m = impl.reference_m + displacement_m;
      WriteDataset(group.get(), "geometry_m", H5T_NATIVE_DOUBLE, deformed_m.data(), impl.num_nodes, 3,
                   impl.h5_path);
      step.geometry = std::string(group_name) + "/geometry_m";
    }
  }
  AppendTime(impl.file, impl.steps.size(), t_s, impl.h5_path);
  Checked(H5Fflush(impl.file, H5F_SCOPE_GLOBAL), "flush the file", impl.h5_path);
  impl.steps.push_back(std::move(step));
  if (impl.XmfDue()) impl.WriteXmf();
}

void XdmfTimeSeriesWriter::Close(bool complete) {
  Impl& impl = *impl_;
  if (impl.closed) return;
  impl.closed = true;
  Quiet();
  // The attribute exists since the constructor: it is rewritten in place,
  // which needs no new space on a full disk.
  try {
    WriteRootAttribute(impl.file, "complete", complete ? 1 : 0, impl.h5_path);
    Checked(H5Fflush(impl.file, H5F_SCOPE_GLOBAL), "flush the file", impl.h5_path);
  } catch (...) {
    h5::CloseFile(impl.file, impl.h5_path);  // closed whatever happened
    throw;
  }
  if (const std::string problem = h5::CloseFile(impl.file, impl.h5_path); !problem.empty()) {
    throw Error(problem, impl.h5_path, kFix);
  }
  // After the .h5 is closed: the description lists nothing the file may lack.
  if (impl.listed != impl.steps.size()) impl.WriteXmf();
}

int XdmfTimeSeriesWriter::num_steps() const { return static_cast<int>(impl_->steps.size()); }
const std::string& XdmfTimeSeriesWriter::h5_path() const { return impl_->h5_path; }
const std::string& XdmfTimeSeriesWriter::xmf_path() const { return impl_->xmf_path; }

}  // namespace dg::io
