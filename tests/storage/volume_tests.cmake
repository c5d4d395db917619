# Tests of the volume readers, the NRRD writer and the field generator
# (storage/volume.cmake). Real volumes are read from ../shared/data when it is
# there; tests that need it skip otherwise. The VTK cross-check runs
# tests/storage/vtk_read_nrrd.py with Debian's python3-vtk9 if installed.
# The tests write gzip NRRD themselves.
find_package(ZLIB REQUIRED)

add_executable(volume_tests
  storage/volume_test.cc
  storage/nrrd_writer_test.cc
  storage/generate_test.cc
  storage/subgrid_time_test.cc
)
target_link_libraries(volume_tests PRIVATE
  simplexdb_volume simplexdb_warnings GTest::gtest_main ZLIB::ZLIB)
target_compile_definitions(volume_tests PRIVATE
  SIMPLEXDB_SHARED_DATA="${PROJECT_SOURCE_DIR}/../shared/data"
  SIMPLEXDB_STORAGE_TEST_DIR="${CMAKE_CURRENT_SOURCE_DIR}/storage")
gtest_discover_tests(volume_tests
  PROPERTIES LABELS storage
  DISCOVERY_TIMEOUT 60)
