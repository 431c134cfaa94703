# paintlab_sim: the simulated world's image formation (config, camera, sensor, flakes,
# renderer, calibration scenes) and the virtual clock. deps: core, brdf.
paintlab_add_library(sim
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/src/builtin.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/camera_model.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/config.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/flakes.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/paint.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/scene_render.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/scenes.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/sensor.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/virtual_clock.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/world.cpp
  DEPS paintlab_core paintlab_brdf
  PRIVATE_DEPS TBB::tbb opencv_core opencv_aruco tomlplusplus::tomlplusplus)

# Built in (sim/builtin.h): the simulated rig and the paint a simulated sample wears.
set(_sim_resources
  rig_sim_toml ${PROJECT_SOURCE_DIR}/examples/rig-sim.toml
  paint_silver_metallic_toml ${PROJECT_SOURCE_DIR}/paints/silver-metallic.toml)
while(_sim_resources)
  list(POP_FRONT _sim_resources _name _file)
  set(_out ${CMAKE_CURRENT_BINARY_DIR}/resource_${_name}.cpp)
  add_custom_command(OUTPUT ${_out}
    COMMAND ${CMAKE_COMMAND} -DINPUT=${_file} -DOUTPUT=${_out} -DNAME=${_name} -DNAMESPACE=paintlab::sim::embedded
            -P ${PROJECT_SOURCE_DIR}/cmake/EmbedText.cmake
    DEPENDS ${_file} ${PROJECT_SOURCE_DIR}/cmake/EmbedText.cmake
    COMMENT "Embedding ${_file}")
  target_sources(paintlab_sim PRIVATE ${_out})
endwhile()
