// ParaView collections (.pvd): a list of VTK XML files (.vtu, .vti) with a
// time each, which ParaView opens as one time series (its reader is
// vtkXMLCollectionReader / vtkPVDReader); and parallel grids (.pvtu), the
// pieces of one mesh (below). The one writer of them:
// `simplexdb extract -o X.pvd` (HP time slices), `simplexdb export -o X.pvd`
// (the field's time steps) and the Python package's Mesh.save("X.pvd").
//
// The file:
//   <?xml version="1.0"?>
//   <VTKFile type="Collection" version="1.0">
//   <Collection>
//   <DataSet timestep="T" part="0" file="NAME"/>     one per data set, in order
//   </Collection>
//   </VTKFile>
// T is the shortest decimal text that reads back as the same double; NAME is
// the data set's file name with XML's special characters escaped. Readers
// resolve NAME against the .pvd's folder, so the data sets are written
// beside it.
//
// Thread safety: reentrant. Cost: O(total length of the names).
//
// Errors: those of WriteFileAtomically (storage/io/file.h): the errno of
// the failing call as a Status naming the file, ResourceExhausted for a full
// disk; nothing is left under `path` then. InvalidArgument naming the data
// set for a timestep that is not finite.
#pragma once

#include <span>
#include <string>

#include "util/status.h"

namespace simplexdb {

struct PvdDataSet {
  double timestep = 0;  // physical time
  std::string file;     // REQUIRES: a file name in the .pvd's folder (no '/')
};

// The collection's text (the format above).
Result<std::string> PvdText(std::span<const PvdDataSet> datasets);

// Writes PvdText(datasets) to `path` atomically.
Status WritePvd(std::span<const PvdDataSet> datasets, const std::string& path);

// A parallel unstructured grid (.pvtu, vtkXMLPUnstructuredGridReader): the
// pieces' .vtu files (names beside the .pvtu, as for a .pvd), each written
// by WriteVtu (query/mesh_io.h), whose arrays it declares: point data
// "field", cell data "error", "level" and "code", Float64 points. The one
// writer of them: `mpirun ... simplexdb extract -o X.pvtu`.
std::string PvtuText(std::span<const std::string> pieces);
Status WritePvtu(std::span<const std::string> pieces, const std::string& path);

// A parallel poly data (.pvtp, vtkXMLPPolyDataReader): the pieces' .vtp
// files of an isosurface, each written by WriteVtp (query/surface_io.h),
// whose arrays it declares: point data "Normals" (Float32, 3), cell data
// "error", Float64 points. The one writer of them: `mpirun ... simplexdb
// isosurface -o X.pvtp`.
std::string PvtpText(std::span<const std::string> pieces);
Status WritePvtp(std::span<const std::string> pieces, const std::string& path);

}  // namespace simplexdb
