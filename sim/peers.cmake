# paintlab_sim_peers: the simulated device peers serving the real protocols (a libmodbus
# server, Aravis' GigE Vision fake camera with our GenICam XML and fill callback, SimLight).
# deps: core, devices (interfaces, register maps, device sections), sim (the world).
set(_peer_deps paintlab_core paintlab_devices paintlab_sim)
add_library(paintlab_sim_peers STATIC
  ${CMAKE_CURRENT_LIST_DIR}/src/peers/turntable_server.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/peers/gige_camera.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/peers/sim_light.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/peers/sim_filter_wheel.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/peers/sim_rig.cpp)
target_include_directories(paintlab_sim_peers
  PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include
  PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src)
target_link_libraries(paintlab_sim_peers
  PUBLIC ${_peer_deps}
  PRIVATE PkgConfig::MODBUS PkgConfig::ARAVIS paintlab_warnings)
set_target_properties(paintlab_sim_peers PROPERTIES POSITION_INDEPENDENT_CODE ON)
