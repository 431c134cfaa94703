# paintlab_sim: the simulated world's image formation (config, camera, sensor, flakes,
# renderer, calibration scenes) and the virtual clock. deps: core, brdf.
paintlab_add_library(sim
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/src/camera_model.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/config.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/flakes.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/paint.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/scenes.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/sensor.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/virtual_clock.cpp
    ${CMAKE_CURRENT_LIST_DIR}/src/world.cpp
  DEPS paintlab_core paintlab_brdf
  PRIVATE_DEPS TBB::tbb opencv_core opencv_aruco)
