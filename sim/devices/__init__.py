"""Simulated devices at the lowest layer: fake MCU bytes, camera frames, BLE adverts, HX711 bits."""
