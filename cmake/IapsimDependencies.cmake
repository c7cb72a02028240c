# Every third-party dependency, found once. All come from Debian packages (tools/install-deps.sh).
find_package(PkgConfig REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
# Boost.Random (header-only): the ziggurat every noise model draws its normals from (sensors/gaussian.h)
find_package(Boost 1.74 REQUIRED CONFIG)
find_package(yaml-cpp REQUIRED)
find_package(spdlog REQUIRED)
find_package(CLI11 REQUIRED)
find_package(cppzmq REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(Threads REQUIRED)
# OpenMP (GCC's libgomp): the RL vector environment steps its environments in parallel (rl/vector_env.h)
find_package(OpenMP REQUIRED)
# HDF5's C library, serial build: the RL data sets in D4RL's layout (rl/dataset.h). Through pkg-config:
# FindHDF5 test-compiles C, a language this project does not enable.
pkg_check_modules(HDF5 REQUIRED IMPORTED_TARGET hdf5-serial)
pkg_check_modules(URDFDOM REQUIRED IMPORTED_TARGET urdfdom)
pkg_check_modules(TINYXML2 REQUIRED IMPORTED_TARGET tinyxml2)
pkg_check_modules(ASSIMP REQUIRED IMPORTED_TARGET assimp)
# the double-precision build (its .pc file adds -DBT_USE_DOUBLE_PRECISION); FindBullet finds only float
pkg_check_modules(BULLET REQUIRED IMPORTED_TARGET bullet-float64)

# gencpp needs Debian's python (the pyenv python on PATH has no ROS modules)
set(IAPSIM_PYTHON /usr/bin/python3 CACHE FILEPATH "Python with python3-genmsg and python3-gencpp")
# pybind11 for the RL environments' Python module (rl/python_module.cc), built for that same Debian python
set(PYBIND11_FINDPYTHON ON)
set(Python_EXECUTABLE ${IAPSIM_PYTHON})
find_package(pybind11 CONFIG REQUIRED)
# Ceres 2.1 (SuiteSparse): the visual-inertial sliding window (vio/factors.h, included only inside vio/)
find_package(Ceres REQUIRED)
# libtorch 1.13 (CPU): the learned policies (rl/torchscript_policy.h)
find_package(Torch REQUIRED)

# ROS1 serialization and bag storage. Their catkin CMake configs run ament's python at configure
# time, so the libraries are located directly instead (see shared NOTES).
function(iapsim_find_library var name)
  find_library(${var} NAMES ${name} REQUIRED)
endfunction()
iapsim_find_library(ROS_SERIALIZATION_LIB roscpp_serialization)
iapsim_find_library(ROS_TIME_LIB rostime)
iapsim_find_library(ROS_CPP_COMMON_LIB cpp_common)
iapsim_find_library(ROSBAG_STORAGE_LIB rosbag_storage)
iapsim_find_library(ROSLZ4_LIB roslz4)
iapsim_find_library(CONSOLE_BRIDGE_LIB console_bridge)
# MuJoCo 2.2 (libmujoco-dev): the reference scene of `iapsim bench physics`, nothing else. Found directly:
# Debian's mujocoConfig.cmake names /usr/include/libqhull_r, which only libqhull-dev installs.
iapsim_find_library(MUJOCO_LIB mujoco)
find_path(MUJOCO_INCLUDE_DIR mujoco/mujoco.h REQUIRED)
find_package(Boost REQUIRED COMPONENTS filesystem system)
find_package(BZip2 REQUIRED)

add_library(iapsim_ros_serialization INTERFACE)
target_link_libraries(iapsim_ros_serialization INTERFACE ${ROS_SERIALIZATION_LIB} ${ROS_TIME_LIB}
                                                        ${ROS_CPP_COMMON_LIB})
add_library(iapsim::ros_serialization ALIAS iapsim_ros_serialization)

# rosbag/bag.h includes pluginlib, class_loader and rcpputils headers from their own folders
add_library(iapsim_rosbag INTERFACE)
target_include_directories(iapsim_rosbag SYSTEM INTERFACE /usr/include/pluginlib /usr/include/class_loader
                                                         /usr/include/rcpputils /usr/include/rcutils
                                                         /usr/include/ament_index_cpp)
target_link_libraries(iapsim_rosbag INTERFACE ${ROSBAG_STORAGE_LIB} ${ROSLZ4_LIB} ${CONSOLE_BRIDGE_LIB}
                                             Boost::filesystem Boost::system iapsim_ros_serialization)
add_library(iapsim::rosbag ALIAS iapsim_rosbag)

# rendering (render/): OSMesa always (headless llvmpipe), EGL behind IAPSIM_RENDER_EGL; GL entry points are
# loaded through the context's GetProcAddress, so nothing links libGL/libOpenGL (linking -lOpenGL before
# -lOSMesa kills every GL call, see shared NOTES).
pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)
pkg_check_modules(LIBDEFLATE REQUIRED IMPORTED_TARGET libdeflate)
# Debian's split OpenCV packages (core, imgproc, imgcodecs, videoio) ship no OpenCVConfig.cmake: find the
# four libraries directly. Used for image decoding, depth PNGs and video, never in a public header.
find_path(OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
add_library(iapsim_opencv INTERFACE)
target_include_directories(iapsim_opencv SYSTEM INTERFACE ${OPENCV_INCLUDE_DIR})
foreach(module core imgproc imgcodecs videoio)
  iapsim_find_library(OPENCV_${module}_LIB opencv_${module})
  target_link_libraries(iapsim_opencv INTERFACE ${OPENCV_${module}_LIB})
endforeach()
add_library(iapsim::opencv ALIAS iapsim_opencv)
# the visual front end's modules (vio/): pyramidal Lucas-Kanade (video) and fundamental-matrix RANSAC (calib3d)
add_library(iapsim_opencv_vision INTERFACE)
foreach(module video calib3d)
  iapsim_find_library(OPENCV_${module}_LIB opencv_${module})
  target_link_libraries(iapsim_opencv_vision INTERFACE ${OPENCV_${module}_LIB})
endforeach()
target_link_libraries(iapsim_opencv_vision INTERFACE iapsim_opencv)
add_library(iapsim::opencv_vision ALIAS iapsim_opencv_vision)
