import click

from conjure.cli.main import main


def test_every_option_of_every_command_states_its_default():
    context = click.Context(main)
    silent = []
    for name in main.list_commands(context):
        command = main.get_command(context, name)
        for option in command.params:
            if isinstance(option, click.Option) and not option.show_default:
                if "default" not in (option.help or "").lower():
                    silent.append(f"{name} {option.opts[0]}")
    assert silent == []
