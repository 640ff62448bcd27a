"""Forward-looking vehicle simulation: cycles, components, controller, driver."""
