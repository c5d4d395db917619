#include "query/pvd_writer.h"

#include <cassert>
#include <charconv>
#include <cmath>

#include "storage/io/file.h"

namespace simplexdb {
namespace {

// `text` as an XML attribute value (in double quotes).
std::string XmlEscaped(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

Result<std::string> PvdText(std::span<const PvdDataSet> datasets) {
  std::string pvd = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n<Collection>\n";
  for (const PvdDataSet& d : datasets) {
    assert(d.file.find('/') == std::string::npos);
    if (!std::isfinite(d.timestep)) {
      return Status::InvalidArgument(d.file + ": the time step of a .pvd's data set must be finite, not " +
                                     std::to_string(d.timestep));
    }
    char time[64];
    // Shortest round-trip text, as fmt's "{}" gives (what the collections
    // always held).
    const auto [end, ec] = std::to_chars(time, time + sizeof time, d.timestep);
    assert(ec == std::errc());
    pvd += "<DataSet timestep=\"" + std::string(time, end) + "\" part=\"0\" file=\"" + XmlEscaped(d.file) + "\"/>\n";
  }
  pvd += "</Collection>\n</VTKFile>\n";
  return pvd;
}

Status WritePvd(std::span<const PvdDataSet> datasets, const std::string& path) {
  SDB_ASSIGN_OR_RETURN(const std::string text, PvdText(datasets));
  return WriteFileAtomically(path, text);
}

std::string PvtuText(std::span<const std::string> pieces) {
  std::string x =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "<PUnstructuredGrid GhostLevel=\"0\">\n"
      "<PPointData Scalars=\"field\">\n<PDataArray type=\"Float64\" Name=\"field\"/>\n</PPointData>\n"
      "<PCellData Scalars=\"error\">\n<PDataArray type=\"Float64\" Name=\"error\"/>\n"
      "<PDataArray type=\"UInt8\" Name=\"level\"/>\n<PDataArray type=\"UInt64\" Name=\"code\"/>\n</PCellData>\n"
      "<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n";
  for (const std::string& piece : pieces) {
    assert(piece.find('/') == std::string::npos);
    x += "<Piece Source=\"" + XmlEscaped(piece) + "\"/>\n";
  }
  x += "</PUnstructuredGrid>\n</VTKFile>\n";
  return x;
}

Status WritePvtu(std::span<const std::string> pieces, const std::string& path) {
  return WriteFileAtomically(path, PvtuText(pieces));
}

std::string PvtpText(std::span<const std::string> pieces) {
  std::string x =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
      "<PPolyData GhostLevel=\"0\">\n"
      "<PPointData Normals=\"Normals\">\n<PDataArray type=\"Float32\" Name=\"Normals\" NumberOfComponents=\"3\"/>\n"
      "</PPointData>\n"
      "<PCellData Scalars=\"error\">\n<PDataArray type=\"Float64\" Name=\"error\"/>\n</PCellData>\n"
      "<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n";
  for (const std::string& piece : pieces) {
    assert(piece.find('/') == std::string::npos);
    x += "<Piece Source=\"" + XmlEscaped(piece) + "\"/>\n";
  }
  x += "</PPolyData>\n</VTKFile>\n";
  return x;
}

Status WritePvtp(std::span<const std::string> pieces, const std::string& path) {
  return WriteFileAtomically(path, PvtpText(pieces));
}

}  // namespace simplexdb
