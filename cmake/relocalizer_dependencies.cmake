# The ROS-free libraries, found the same way by the package (CMakeLists.txt) and
# by the fuzz build (test/fuzz/CMakeLists.txt). One code base for the library
# generations of Debian 11 to 13 and Ubuntu 20.04 to 24.04: Eigen 3.3 and 3.4,
# OpenCV 4.2 to 4.10, Ceres 1.14 to 2.2, TBB 2020 and oneTBB.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs)
# Ceres' version file accepts only its own major version, so 1.14 (Debian 11,
# Ubuntu 20.04) and 2.x cannot be asked for in one find_package call.
find_package(Ceres REQUIRED)
if(Ceres_VERSION VERSION_LESS 1.14)
  message(FATAL_ERROR "Ceres ${Ceres_VERSION} found in ${Ceres_DIR}: relocalizer needs 1.14 or newer")
endif()
# Ceres 1.14 exports its library as `ceres`, 2.x as Ceres::ceres: link the latter.
if(NOT TARGET Ceres::ceres)
  add_library(Ceres::ceres INTERFACE IMPORTED)
  set_target_properties(Ceres::ceres PROPERTIES INTERFACE_LINK_LIBRARIES ceres)
endif()
find_package(TBB REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(ZLIB REQUIRED)
