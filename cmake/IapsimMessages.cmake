# iapsim_add_messages(TARGET name PACKAGE pkg FILES a.msg ... DEPENDS std_msgs geometry_msgs ...)
# Generates C++ headers for ROS1 .msg files at build time with Debian's genmsg/gencpp and exposes them
# through an INTERFACE target. Generated headers land in ${CMAKE_BINARY_DIR}/gen/<pkg>/<Type>.h.
function(iapsim_add_messages)
  cmake_parse_arguments(ARG "" "TARGET;PACKAGE" "FILES;DEPENDS" ${ARGN})
  set(gen_root ${CMAKE_BINARY_DIR}/gen)
  set(out_dir ${gen_root}/${ARG_PACKAGE})
  set(search_paths -I${ARG_PACKAGE}:${CMAKE_CURRENT_SOURCE_DIR}/msg)
  foreach(dep ${ARG_DEPENDS})
    if(NOT EXISTS /usr/share/${dep}/msg)
      message(FATAL_ERROR "message package ${dep}: /usr/share/${dep}/msg not found (install ros-*-msgs)")
    endif()
    list(APPEND search_paths -I${dep}:/usr/share/${dep}/msg)
  endforeach()
  # a message may nest other messages of the same package: regenerate on any change
  set(all_msgs "")
  foreach(msg ${ARG_FILES})
    list(APPEND all_msgs ${CMAKE_CURRENT_SOURCE_DIR}/${msg})
  endforeach()
  set(headers "")
  foreach(msg ${ARG_FILES})
    get_filename_component(type ${msg} NAME_WE)
    set(header ${out_dir}/${type}.h)
    add_custom_command(
      OUTPUT ${header}
      COMMAND ${IAPSIM_PYTHON} /usr/lib/gencpp/gen_cpp.py -p ${ARG_PACKAGE} -o ${out_dir}
              -e /usr/share/gencpp ${search_paths} ${CMAKE_CURRENT_SOURCE_DIR}/${msg}
      DEPENDS ${all_msgs}
      COMMENT "gencpp ${ARG_PACKAGE}/${type}"
      VERBATIM)
    list(APPEND headers ${header})
  endforeach()
  add_custom_target(${ARG_TARGET}_generate DEPENDS ${headers})
  add_library(${ARG_TARGET} INTERFACE)
  add_dependencies(${ARG_TARGET} ${ARG_TARGET}_generate)
  target_include_directories(${ARG_TARGET} INTERFACE ${gen_root})
  target_link_libraries(${ARG_TARGET} INTERFACE iapsim::ros_serialization)
endfunction()
