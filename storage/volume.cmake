# simplexdb_volume: the input side of the dense store. Reads volumes (raw,
# NRRD raw/gzip, NIfTI-1), writes NRRD, and generates synthetic fields
# (storage/volume.h, nrrd_writer.h, generate.h), and makes 4D volumes from 3D
# ones (subgrid_time.h). zlib decodes gzip NRRD
# (Debian: zlib1g-dev).
find_package(ZLIB REQUIRED)

add_library(simplexdb_volume STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/voxel_type.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/volume.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/nrrd_writer.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/generate.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/subgrid_time.cc
)
target_include_directories(simplexdb_volume PUBLIC
  $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
  $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/simplexdb>)
target_link_libraries(simplexdb_volume
  PUBLIC simplexdb_util
  PRIVATE simplexdb_warnings ZLIB::ZLIB)

# Synthetic fields must be the same bits on every machine (generate.h): no
# fused multiply-adds, which would round differently where the CPU has them.
set_source_files_properties(${CMAKE_CURRENT_SOURCE_DIR}/generate.cc
  PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
